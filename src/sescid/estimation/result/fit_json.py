"""The fit file: a ``Fit`` as JSON (``"format": "sescid-fit/3"``), written atomically.

Keys: ``robot`` {``source`` (embedded name or model file path), ``name``, ``support``,
``joint_names``, ``body_names``, ``total_mass`` [kg]}, ``method`` ("ls", "map", "consistent"),
``method_label``, ``rank``, ``n_poses``, ``n_rows``, ``rtol``, ``sigma_hat``/``rms``/``mae`` [m],
``weighted``, ``sigma_dof``, ``r`` and ``r_prior`` {body: [x, y, z] m, body frame}, ``r_std``,
``cov`` (3N × 3N, m², body-major then x, y, z), ``basis`` (3N × rank), ``singular_values``,
``base_combinations`` and ``unidentifiable`` (lists of {terms [[body, axis, coef]], label, value,
std, reason, kind}), ``notes`` (generated, for reading), ``warnings``, and one object per typed
record that is present: ``map``, ``cop_offset``, ``inertials``, ``robust``, ``online``, ``cv``,
``joint_noise``, ``truth_cop_rmse``; ``kinds`` (per measurement kind: rows, noise, residuals, in
its own unit), ``nuisance`` (sensor offsets, friction bands: value, std, determined, reason),
``torque_noise`` (each torque sensor's σ_j when estimated per joint: sigma, dof, rms, by, rows,
unit), ``total_mass`` and ``mass_given`` (the scale of torque rows), ``gravity_accel`` [m/s²], and
``payload`` when one was identified (``payload_record``: body, mass, com, their stds). Lengths in
m, masses in kg, angles in rad, torques in N·m; a quantity the data do not determine is ``null``.
Versions 1 and 2 are read (version 1: method-specific results in a free ``extra`` object); a
file of another version is refused with a message that says so.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, cast

import numpy as np

from sescid.base import G0
from sescid.base.files import atomic_open, read_json
from sescid.errors import DataError, SescidError
from sescid.estimation.result import records
from sescid.estimation.result.fit import METHODS, Combination, Fit, Method
from sescid.estimation.result.notes import fit_notes
from sescid.estimation.result.payload_record import payload_from_json, payload_to_json
from sescid.estimation.result.records import json_ready
from sescid.robot import Robot, load_robot

FIT_FORMAT = "sescid-fit/3"
FIT_FORMAT_V2 = "sescid-fit/2"
FIT_FORMAT_V1 = "sescid-fit/1"
FIT_FORMATS = (FIT_FORMAT_V1, FIT_FORMAT_V2, FIT_FORMAT)
_RECORDS: dict[str, type] = {
    "map": records.MapInfo,
    "cop_offset": records.CopOffset,
    "scale": records.ScaleAnchor,
    "choice": records.MethodChoice,
    "inertials": records.BodyInertials,
    "robust": records.RobustInfo,
    "online": records.OnlineInfo,
    "cv": records.CrossValidation,
    "joint_noise": records.JointNoiseEffect,
}
#: the fit's tuples of records (a record per kind, nuisance parameter, torque sensor)
_RECORD_TUPLES: dict[str, type] = {
    "kinds": records.KindFit,
    "nuisance": records.NuisanceEstimate,
    "torque_noise": records.JointNoise,
}


def _record_to_json(rec: Any) -> dict:
    return {f.name: json_ready(getattr(rec, f.name)) for f in dataclasses.fields(rec)}


def _record_from_json(cls: type, d: dict, where: str) -> Any:
    kw = {}
    for f in dataclasses.fields(cls):
        if f.name not in d:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise DataError(f"{where}: missing field '{f.name}'")
            continue
        v = d[f.name]
        kind = str(f.type)
        if "np.ndarray" in kind and v is not None:
            v = np.array(v, dtype=float)
        elif kind.startswith("float") and v is None and "None" not in kind:
            v = math.nan
        elif f.name == "downweighted":
            v = [(int(i), float(w)) for i, w in v]
        kw[f.name] = v
    return cls(**kw)


def fit_to_json(fit: Fit) -> dict:
    """The fit file's content as a JSON-ready dict."""
    robot = fit.robot
    bodies = robot.body_names
    out: dict[str, Any] = {
        "format": FIT_FORMAT,
        "robot": {
            "source": robot.source,
            "name": robot.name,
            "support": robot.support,
            "line": None if robot.line is None else robot.line.tolist(),
            "joint_names": robot.joint_names,
            "body_names": bodies,
            "total_mass": robot.total_mass,
            "r_model": {b: v for b, v in zip(bodies, robot.sesc_vectors().tolist(), strict=True)},
        },
        "method": fit.method,
        "method_label": fit.method_label,
        "rank": fit.rank,
        "n_poses": fit.n_poses,
        "n_rows": fit.n_rows,
        "rtol": fit.rtol,
        "sigma_hat": json_ready(fit.sigma_hat),
        "rms": json_ready(fit.rms),
        "mae": json_ready(fit.mae),
        "weighted": fit.weighted,
        "sigma_dof": json_ready(fit.sigma_dof) if fit.sigma_dof != math.inf else "inf",
        "units": "m (r, r_std, sigma_hat, rms, mae), m^2 (cov), kg (masses)",
        "r": {b: fit.r[i].tolist() for i, b in enumerate(bodies)},
        "r_prior": {b: fit.r_prior[i].tolist() for i, b in enumerate(bodies)},
        "r_std": {b: json_ready(fit.r_std[i]) for i, b in enumerate(bodies)},
        "cov": json_ready(fit.cov),
        "basis": fit.basis.tolist(),
        "singular_values": fit.singular_values.tolist(),
        "base_combinations": [c.to_json() for c in fit.base],
        "unidentifiable": [c.to_json() for c in fit.unidentifiable],
        "weak": [c.to_json() for c in fit.weak],
        "notes": fit_notes(fit),
        "warnings": list(fit.warnings),
        **{key: [_record_to_json(e) for e in getattr(fit, key)] for key in _RECORD_TUPLES},
        "total_mass": json_ready(fit.total_mass),
        "mass_given": fit.mass_given,
        "gravity_accel": fit.gravity_accel,
    }
    for key in _RECORDS:
        rec = getattr(fit, key)
        if rec is not None:
            out[key] = _record_to_json(rec)
    if fit.truth_cop_rmse is not None:
        out["truth_cop_rmse"] = fit.truth_cop_rmse
    if fit.bodies is not None:
        b = fit.bodies
        out["bodies"] = {
            "x": b.x.tolist(),
            "x_prior": b.x_prior.tolist(),
            "cov": json_ready(b.cov),
            "information": b.information.tolist(),
            "rank": b.rank,
            "stances": [_record_to_json(st) for st in b.stances],
            "added": list(b.added),
            "total_mass": b.total_mass,
        }
    if fit.payload is not None:
        out["payload"] = payload_to_json(fit.payload)
    return out


def _bodies_from_json(d: dict, n: int, path: Path):
    """The ``BodyFit`` of a pooled fit's file."""
    from sescid.estimation.sums.pooled import BodyFit, StanceRank

    size = 4 * n
    return BodyFit(
        x=_matrix(d, "x", (size,), path),
        x_prior=_matrix(d, "x_prior", (size,), path),
        cov=_matrix(d, "cov", (size, size), path, nullable=True),
        information=_matrix(d, "information", (size, size), path),
        rank=int(d["rank"]),
        stances=tuple(
            _record_from_json(StanceRank, st, f"{path}: field 'bodies'") for st in d["stances"]
        ),
        added=tuple(str(a) for a in d.get("added", [])),
        total_mass=float(d["total_mass"]),
    )


def save_fit(fit: Fit, path: str | Path) -> None:
    """Write a fit as JSON, atomically."""
    with atomic_open(path, "w") as fh:
        json.dump(fit_to_json(fit), fh, indent=1, allow_nan=False)
        fh.write("\n")


def _v1_records(extra: dict, method: str) -> dict[str, Any]:
    """Typed records from a version-1 ``extra`` object."""
    out: dict[str, Any] = {"weighted": bool(extra.get("weighted", False))}
    if "dof" in extra:
        out["sigma_dof"] = math.inf if extra["dof"] is None else float(extra["dof"])
    if "prior_scale_m" in extra:
        out["map"] = records.MapInfo(
            prior_scale=float(extra["prior_scale_m"]),
            prior_scale_by=str(extra.get("prior_scale_chosen_by", "given")),
            noise=float(extra.get("noise_m", math.nan)),
            noise_by=str(extra.get("noise_chosen_by", "given")),
            log_evidence=float(extra.get("log_evidence", math.nan)),
            effective_parameters=float(extra.get("effective_parameters", math.nan)),
            cv_curve=extra.get("cv_curve"),
        )
    if "bias" in extra:
        out["cop_offset"] = records.CopOffset(
            np.array(extra["bias"], float), np.array(extra.get("bias_std", [0, 0]), float)
        )
    if "robust" in extra:
        r = extra["robust"]
        out["robust"] = records.RobustInfo(
            k=float(r["k"]),
            scale=float(r["scale_m"]),
            iterations=int(r["iterations"]),
            downweighted=[(int(i), float(w)) for i, w in r["downweighted"]],
            weighted_input=bool(extra.get("weighted", False)),
        )
    if "bodies" in extra:
        names = list(extra["bodies"])
        rows = [extra["bodies"][n] for n in names]
        out["inertials"] = records.BodyInertials(
            masses=np.array([b["mass_kg"] for b in rows], float),
            coms=np.array([b["com_m"] for b in rows], float),
            coms_link=np.array([b.get("com_link_m", b["com_m"]) for b in rows], float),
            box_lo=np.array([b.get("box_lo_m", [-np.inf] * 3) for b in rows], float),
            box_hi=np.array([b.get("box_hi_m", [np.inf] * 3) for b in rows], float),
            box_source=[str(b.get("box_source", "")) for b in rows],
            total_mass=float(extra.get("total_mass_kg", sum(b["mass_kg"] for b in rows))),
            mass_floor=float(extra.get("mass_floor_kg", 0.0)),
            symmetric=bool(extra.get("symmetric", False)),
            com_scale=float(extra.get("com_scale_m", math.nan)),
            fit_tol=float(extra.get("fit_tol_m", math.nan)),
            prior_std=extra.get("prior_std"),
            active_constraints=list(extra.get("active_constraints", [])),
            mirror_pairs=list(extra.get("mirror_pairs", [])),
            source_method=str(extra.get("source_method", method)),
            source_rms=math.nan,
            cop_rss_increase=float(extra.get("cop_rss_increase_m2", 0.0)),
            cad_masses=np.array([b.get("cad_mass_kg", math.nan) for b in rows], float),
        )
    if "cv" in extra:
        c = extra["cv"]
        out["cv"] = records.CrossValidation(
            int(c["k"]), c["cop_rmse_m"], c["cop_rmse_folds_m"], c["noise_m"], c["model_rmse_m"]
        )
    if "truth_cop_rmse_m" in extra:
        out["truth_cop_rmse"] = float(extra["truth_cop_rmse_m"])
    return out


def _v1_method(method: str) -> str:
    base = method.split("+")[0].removeprefix("online-")
    return {"least-squares": "ls"}.get(base, base)


def _method(text: str, path: Path) -> Method:
    """The fit's method, one of ``METHODS`` (DataError naming the file otherwise)."""
    if text not in METHODS:
        raise DataError(f"{path}: field 'method': {text!r} is not one of {', '.join(METHODS)}")
    return cast(Method, text)


def _matrix(
    data: dict, key: str, shape: tuple[int, ...], path: Path, nullable: bool = False
) -> np.ndarray:
    """A numeric field of the given shape; ``nullable``: null entries are "not determined"
    (nan), all or none of them (a covariance without degrees of freedom)."""
    raw = data[key]
    arr = np.array(raw, dtype=float) if raw is not None else np.full(shape, np.nan)
    if arr.shape != shape:
        raise DataError(f"{path}: field '{key}' has shape {arr.shape}, expected {shape}")
    finite = np.isfinite(arr)
    if not np.all(finite) and not (nullable and not np.any(np.isinf(arr))):
        raise DataError(f"{path}: field '{key}' has non-finite values")
    return arr


def _read(path: Path) -> dict:
    """The fit file's JSON; a one-line error for another format version of the fit file."""
    try:
        return read_json(path, FIT_FORMATS, "a sescid fit")
    except DataError:
        try:
            fmt = json.loads(path.read_text()).get("format", "")
        except (OSError, ValueError, AttributeError):
            fmt = ""
        if isinstance(fmt, str) and fmt.startswith("sescid-fit/"):
            raise DataError(
                f"{path}: fit file format {fmt!r} is not one this sescid reads "
                f"({', '.join(FIT_FORMATS)}): written by another version of sescid"
            ) from None
        raise


def load_fit(path: str | Path) -> Fit:
    """Read a fit written by ``save_fit`` (this version, and versions 1 and 2 with a warning
    ``OLD_FORMAT``: a not-determined covariance they stored as zeros is read as nan again);
    reloads its robot."""
    path = Path(path)
    data = _read(path)
    v1 = data["format"] == FIT_FORMAT_V1
    try:
        meta = data["robot"]
        robot = load_robot(meta["source"], meta["support"], meta.get("line"))
        if robot.body_names != meta["body_names"] or robot.joint_names != meta["joint_names"]:
            raise DataError(
                f"{path}: the robot '{meta['source']}' no longer has the bodies/joints this "
                "fit was made for"
            )
        bodies = robot.body_names
        n = 3 * len(bodies)
        r = _matrix({"r": [data["r"][b] for b in bodies]}, "r", (len(bodies), 3), path)
        r_prior = _matrix(
            {"r_prior": [data["r_prior"][b] for b in bodies]}, "r_prior", (len(bodies), 3), path
        )
        rank = int(data["rank"])
        nan = float("nan")
        fields: dict[str, Any] = {}
        if v1:
            method = _method(_v1_method(str(data["method"])), path)
            fields = _v1_records(dict(data.get("extra") or {}), method)
        else:
            method = _method(str(data["method"]), path)
            fields["weighted"] = bool(data.get("weighted", False))
            dof = data.get("sigma_dof")
            fields["sigma_dof"] = math.inf if dof == "inf" else (None if dof is None else dof)
            fields["warnings"] = tuple(str(w) for w in data.get("warnings", []))
            for key, cls in _RECORD_TUPLES.items():
                fields[key] = tuple(
                    _record_from_json(cls, e, f"{path}: field '{key}'") for e in data.get(key, [])
                )
            if data.get("total_mass") is not None:
                fields["total_mass"] = float(data["total_mass"])
            fields["mass_given"] = bool(data.get("mass_given", False))
            fields["gravity_accel"] = float(
                data.get("gravity_accel", fields.get("gravity_accel", G0))
            )
            for key, cls in _RECORDS.items():
                if data.get(key) is not None:
                    fields[key] = _record_from_json(cls, data[key], f"{path}: field '{key}'")
            if data.get("truth_cop_rmse") is not None:
                fields["truth_cop_rmse"] = float(data["truth_cop_rmse"])
            if data.get("bodies") is not None:
                fields["bodies"] = _bodies_from_json(data["bodies"], len(bodies), path)
            if data.get("payload") is not None:
                fields["payload"] = payload_from_json(data["payload"], f"{path}: field 'payload'")
        cov = _matrix(data, "cov", (n, n), path, nullable=True)
        sigma_null = data["sigma_hat"] is None
        if data["format"] != FIT_FORMAT and sigma_null:
            cov = np.full((n, n), np.nan)  # versions 1, 2 wrote a not-determined cov as zeros
        fit = Fit(
            robot=robot,
            r=r,
            r_prior=r_prior,
            cov=cov,
            basis=_matrix(data, "basis", (n, rank), path) if rank else np.zeros((n, 0)),
            singular_values=_matrix(data, "singular_values", (n,), path),
            rank=rank,
            n_poses=int(data["n_poses"]),
            n_rows=int(data["n_rows"]),
            sigma_hat=nan if data["sigma_hat"] is None else float(data["sigma_hat"]),
            rms=nan if data["rms"] is None else float(data["rms"]),
            mae=nan if data["mae"] is None else float(data["mae"]),
            rtol=float(data["rtol"]),
            method=method,
            base=tuple(Combination.from_json(c) for c in data["base_combinations"]),
            unidentifiable=tuple(Combination.from_json(c) for c in data["unidentifiable"]),
            weak=tuple(Combination.from_json(c) for c in data.get("weak", [])),
            **fields,
        )
        changed = _model_change(path, meta, robot)
    except SescidError:
        raise
    except KeyError as exc:
        raise DataError(f"{path}: malformed fit file (field {exc} missing)") from None
    except (TypeError, ValueError, IndexError) as exc:
        raise DataError(f"{path}: malformed fit file ({exc.__class__.__name__}: {exc})") from None
    if changed is not None:
        fit = dataclasses.replace(fit, warnings=(changed, *fit.warnings))
    if data["format"] != FIT_FORMAT:
        old = (
            f"{OLD_FORMAT} {data['format']!r} (this sescid writes {FIT_FORMAT}): read as such — "
            "its noise, covariance and notes are those of the sescid that wrote it; refit to "
            "store what this version records (each kind's fit, the sensors' estimates)"
        )
        fit = dataclasses.replace(fit, warnings=(old, *fit.warnings))
    return fit


#: the start of the warning a fit read from an older file format carries
OLD_FORMAT = "an older fit file format"


#: the start of the warning a fit read back carries when its model file changed since the fit
MODEL_CHANGED = "the model changed since this fit"
#: relative change of the total mass, and change of an SESC vector [m], taken as a model change
MODEL_TOL_MASS, MODEL_TOL_R = 1e-9, 1e-9


def _model_change(path: Path, meta: dict, robot: Robot) -> str | None:
    """A ``MODEL_CHANGED`` warning when the model's total mass or SESC vectors differ from the
    ones stored at fit time (files without them: None)."""
    mass0 = float(meta["total_mass"])
    dm = abs(robot.total_mass - mass0)
    dr = 0.0
    if meta.get("r_model") is not None:
        r0 = np.array([meta["r_model"][b] for b in robot.body_names], dtype=float)
        dr = float(np.abs(robot.sesc_vectors() - r0).max())
    if dm <= MODEL_TOL_MASS * mass0 and dr <= MODEL_TOL_R:
        return None
    return (
        f"{MODEL_CHANGED}: '{meta['source']}' now weighs {robot.total_mass:.4g} "
        f"kg ({mass0:.4g} kg at fit time), its SESC vectors moved by up to {dr * 1e3:.3g} mm; "
        "refit with the current model, or restore the model the fit was made with"
    )
