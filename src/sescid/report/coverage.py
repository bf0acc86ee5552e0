"""What each kind of data determines at the report's poses, and what pooling them gives.

For each measurement kind present (and for all of them pooled, each weighed by the fit's noise
of that kind), the information the rows carry about vec(r) once the kind's sensor terms are
marginalised (a constant offset per torque sensor, its friction band when the approach side is
known, a CoP offset when the fit estimated one), and its rank by the fit's own rule
(``identifiable_eigen`` at ``fit.rtol``). The directions left out are named by the estimation's
rule (support body, joint axes, not excited). No fitting: regressors and eigenvalues only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.estimation import Combination, Fit, Kind, Measurements, identifiable_eigen
from sescid.estimation.result.identifiability import label_columns, unidentifiable
from sescid.kinds import Kinds
from sescid.report.numbers import project_out, torque_nuisance_columns

#: rows per block when summing ΦᵀΦ (bounded memory for long data sets)
COVERAGE_BLOCK = 512


@dataclass(frozen=True)
class Coverage:
    """What one kind of data (or several pooled) determines: the rank of its information about
    vec(r) (3N) and the named directions it leaves out."""

    kinds: Kinds  #: ("cop",), ("tau",) or ("cop", "tau")
    rank: int
    n_par: int  #: 3N
    unseen: tuple[Combination, ...]

    def count(self, kind: str) -> int:
        """Unseen directions of one ``Combination.kind`` ("support-vertical", …)."""
        return sum(c.kind == kind for c in self.unseen)


def _cop_rows(fit: Fit, data: Measurements, rows: slice) -> np.ndarray:
    """CoP regressor rows (m, 2, 3N) of the poses ``rows`` (tilted under gravity columns)."""
    q = data.q[rows]
    if data.gravity is None:
        return fit.robot.regressor(q)
    return fit.robot.regressor_tilted(q, data.gravity[rows])


def cop_information(fit: Fit, data: Measurements) -> np.ndarray:
    """ΦᵀWΦ (3N, 3N) of the CoP rows (weighted as the fit was), a CoP offset marginalised."""
    k = fit.kind("cop")
    se = data.cop_se if k is not None and k.weighted else None
    sw = np.ones((data.n, 2)) if se is None else 1.0 / se
    n_par = 3 * len(fit.robot.body_names)
    ata = np.zeros((n_par, n_par))
    if fit.cop_offset is not None:  # a constant offset per axis: projected out over all poses
        phi = _cop_rows(fit, data, slice(None))
        for a in range(2):
            x = project_out(phi[:, a] * sw[:, a, None], sw[:, a, None])
            ata += x.T @ x
        return ata
    for s in range(0, data.n, COVERAGE_BLOCK):
        phi = (
            _cop_rows(fit, data, slice(s, s + COVERAGE_BLOCK)) * sw[s : s + COVERAGE_BLOCK, :, None]
        )
        ata += np.einsum("mai,maj->ij", phi, phi)
    return ata


def torque_information(fit: Fit, data: Measurements) -> np.ndarray:
    """ΦᵀWΦ (3N, 3N) of the torque rows (M·Φ_τ, weighted as the fit was), each sensor's offset
    (and friction band, with approach sides) marginalised."""
    robot = fit.robot
    assert data.tau is not None
    k = fit.kind("tau")
    weighted = k is not None and k.weighted and data.tau_se is not None
    mass = fit.total_mass if math.isfinite(fit.total_mass) else robot.total_mass
    phi = mass * robot.torque_regressor(data.q, data.tau_joints, data.gravity, fit.gravity_accel)
    nuis = torque_nuisance_columns(data.n, data.approach)
    ata = np.zeros((phi.shape[2],) * 2)
    for j in range(len(data.tau_joints)):  # per joint: its own offset (and band)
        sw = 1.0 / data.tau_se[:, j] if weighted and data.tau_se is not None else np.ones(data.n)
        x = project_out(phi[:, j] * sw[:, None], nuis * sw[:, None])
        ata += x.T @ x
    return ata


def _weight(fit: Fit, kind: Kind, ata: np.ndarray) -> float:
    """1/σ² of a kind for pooling (the fit's noise of that kind; else its information's scale)."""
    k = fit.kind(kind)
    if k is not None and math.isfinite(k.sigma) and k.sigma > 0:
        return 1.0 / k.sigma**2
    top = float(np.linalg.eigvalsh(ata)[-1]) if ata.size else 0.0
    return 1.0 / top if top > 0 else 1.0


def coverage(fit: Fit, data: Measurements) -> tuple[Coverage, ...]:
    """One ``Coverage`` per kind present in ``data`` (validated), then the pooled one when
    there are several."""
    robot = fit.robot
    labels = label_columns(robot)
    infos: dict[Kind, np.ndarray] = {}
    if data.cop is not None:
        infos["cop"] = cop_information(fit, data)
    if data.tau is not None and data.tau_joints:
        infos["tau"] = torque_information(fit, data)
    groups: list[tuple[Kinds, np.ndarray]] = [((k,), a) for k, a in infos.items()]
    if len(infos) > 1:
        pooled = sum(_weight(fit, k, a) * a for k, a in infos.items())
        groups.append((tuple(infos), np.asarray(pooled)))
    out = []
    for kinds, ata in groups:
        _, basis = identifiable_eigen((ata + ata.T) / 2, fit.rtol)
        named = unidentifiable(robot, basis, labels, kinds)
        out.append(Coverage(kinds, basis.shape[1], ata.shape[0], tuple(named)))
    return tuple(out)
