"""Every import of sescid is a declared dependency: with only the core dependencies importable
(what `pip install sescid` gives), every module imports, the main commands run, and a feature
that needs an extra says which one, in one line (MissingExtraError).

The check runs in a subprocess whose import system refuses every third-party module outside the
transitive closure of sescid's core requirements (read from the installed metadata), so an
import of an optional package (mujoco, rosbags, viser, trimesh, pycollada, pinocchio, yourdfpy,
lxml, hypothesis, example_robot_data, ruamel.yaml, …) fails there as on a plain install.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent(
    r'''
    import importlib, json, os, pkgutil, re, sys, tempfile
    from importlib import metadata
    from pathlib import Path

    def norm(name):
        return re.sub(r"[-_.]+", "-", name).lower()

    def closure(dist):
        """Distributions sescid's core requirements pull in (extras and markers excluded)."""
        from packaging.requirements import Requirement
        seen, todo = set(), [dist]
        while todo:
            d = todo.pop()
            if norm(d) in seen:
                continue
            seen.add(norm(d))
            try:
                reqs = metadata.requires(d) or []
            except metadata.PackageNotFoundError:
                continue
            for text in reqs:
                req = Requirement(text)
                if req.marker is not None and not req.marker.evaluate({"extra": ""}):
                    continue
                todo.append(req.name)
        return seen

    allowed_dists = closure("sescid")
    allowed = {"sescid", "packaging"} | set(sys.stdlib_module_names)
    for top, dists in metadata.packages_distributions().items():
        if any(norm(d) in allowed_dists for d in dists):
            allowed.add(top)
    blocked_seen = set()

    class CoreOnly:
        """Refuse third-party modules outside the core closure, as if not installed."""
        def find_spec(self, name, path=None, target=None):
            top = name.split(".")[0]
            if top in allowed or top.startswith("_") or top in sys.builtin_module_names:
                return None
            blocked_seen.add(top)
            msg = f"No module named {name!r} (not a core dependency)"
            raise ModuleNotFoundError(msg, name=name)

    for mod in [m for m in sys.modules if m.split(".")[0] not in allowed and not m.startswith("_")]:
        del sys.modules[mod]
    sys.meta_path.insert(0, CoreOnly())

    out = {"import_errors": [], "extras": {}, "commands": {}}
    import sescid
    for info in pkgutil.walk_packages(sescid.__path__, "sescid."):
        try:
            importlib.import_module(info.name)
        except Exception as exc:
            out["import_errors"].append(f"{info.name}: {exc.__class__.__name__}: {exc}")

    from sescid.errors import MissingExtraError

    def extra(label, call):
        try:
            call()
            out["extras"][label] = "no error"
        except MissingExtraError as exc:
            out["extras"][label] = str(exc)
        except Exception as exc:
            out["extras"][label] = f"{exc.__class__.__name__}: {exc}"

    tmp = Path(tempfile.mkdtemp())
    body = '<body name="a"><joint/><geom size="1"/></body>'
    (tmp / "m.xml").write_text(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
    (tmp / "map.yaml").write_text("format: sescid-bag-mapping/1\n")
    from sescid.io.bags import parse_mapping, read_bag
    mp = parse_mapping({"format": "sescid-bag-mapping/1", "joints": {"topic": "/j"},
                        "feet": {"right": {"source": "pads", "topic": "/f"}}})
    extra("mjcf", lambda: sescid.load_robot(tmp / "m.xml", support="a"))
    extra("bag", lambda: read_bag(tmp, mp, ["a"]))
    from sescid.base.files import read_document
    from sescid.bench.mujoco.spec import BENCH_NEEDS
    from sescid.model.mjcf_compile import mujoco_module
    from sescid.model import meshes
    from sescid.report import live
    extra("yaml", lambda: read_document(tmp / "map.yaml"))
    extra("meshes", lambda: meshes._hull_vertices(str(tmp / "x.obj")))  # STL: numpy alone
    extra("view", lambda: live._viser())
    extra("bench", lambda: mujoco_module(BENCH_NEEDS))

    from click.testing import CliRunner
    from sescid.cli import cli
    runner = CliRunner()
    steps = {
        "simulate": ["simulate", "--count", "60", "--out", str(tmp / "sim.csv")],
        "identify": ["identify", str(tmp / "sim.csv"), "--method", "consistent",
                     "--allow-outside-limits", "--out", str(tmp / "fit.json")],
        "export": ["export", str(tmp / "fit.json"), "--out", str(tmp / "op2.urdf")],
        "bag": ["bag", str(tmp), "--map", str(tmp / "map.yaml"),
                "--out", str(tmp.parent / "raw.csv")],
        "session": ["session", "--budget", "30", "--out-dir", str(tmp / "s1")],
        "session-kinematic": ["session", "--adapter", "kinematic", "--budget", "30",
                              "--out-dir", str(tmp / "s2")],
    }
    for name, args in steps.items():
        res = runner.invoke(cli, args)
        exc = res.exception if not isinstance(res.exception, SystemExit) else None
        out["commands"][name] = [res.exit_code, res.output, repr(exc) if exc else None]
    out["blocked"] = sorted(blocked_seen)
    print(json.dumps(out))
    '''
)


@pytest.fixture(scope="module")
def core_only():
    res = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=False, timeout=600
    )
    assert res.returncode == 0, res.stderr[-3000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


def test_every_module_imports_with_the_core_dependencies(core_only):
    assert core_only["import_errors"] == []


@pytest.mark.parametrize(
    ("label", "extra"),
    [
        ("mjcf", "mujoco"),
        ("bag", "bags"),
        ("yaml", "bags"),
        ("meshes", "meshes"),
        ("view", "view"),
        ("bench", "mujoco"),
    ],
)
def test_a_feature_needing_an_extra_names_it(core_only, label, extra):
    msg = core_only["extras"][label]
    assert msg.endswith(
        f"needs the {extra} extra: pip install 'sescid[{extra}]' (in a clone of the "
        f"repository: pip install '.[{extra}]')"
    ), msg
    assert "\n" not in msg


def test_main_commands_run_on_a_core_install(core_only):
    """simulate → identify --method consistent → export URDF (no lxml, no extras); `bag`
    names its extra in one line."""
    cmds = core_only["commands"]
    for name in ("simulate", "identify", "export"):
        code, output, exc = cmds[name]
        assert code == 0 and exc is None, (name, output, exc)
    code, output, exc = cmds["bag"]
    assert code == 2 and exc is None
    assert output.startswith("sescid: error: ") and output.count("\n") == 1
    assert output.endswith("pip install 'sescid[bags]' (in a clone of the repository: "
                           "pip install '.[bags]')\n")  # fmt: skip


def test_the_blocker_blocks(core_only):
    """The optional packages sescid tried to import were refused (the check can fail)."""
    assert {"mujoco", "ruamel"} <= set(core_only["blocked"])


def test_session_on_a_core_install_names_the_way_without_the_extras(core_only):
    """`session` defaults to the physics bench and the live view: each missing extra's line
    names the flag that does without it."""
    code, output, _ = core_only["commands"]["session"]
    assert code == 2 and output.count("\n") == 1, output
    assert "sescid[mujoco]" in output and output.endswith(
        "; or run the rigid-statics bench without it: --adapter kinematic\n"
    )
    code, output, _ = core_only["commands"]["session-kinematic"]
    assert code == 2 and output.count("\n") <= 2, output
    assert "sescid[view]" in output and output.endswith("; or run without it: --no-view\n")
