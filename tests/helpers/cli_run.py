"""The command line run in process for the tests: ``sescid ARGS`` through click's runner, a
traceback always a failure of the test (never an answer), and a small robot file to run it on."""

from __future__ import annotations

from click.testing import CliRunner, Result

from sescid.cli import cli

#: a two-body robot standing on a box foot, one hinge (no profile, no sensor layout)
STICK_URDF = """<robot name="stick"><link name="foot"><inertial><origin xyz="0 0 0.02"/>
<mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
</inertial><collision><origin xyz="0 0 0.02"/><geometry><box size="0.2 0.12 0.04"/>
</geometry></collision></link><link name="body"><inertial><origin xyz="0 0 0.15"/>
<mass value="2"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
</inertial></link><joint name="ankle" type="revolute"><parent link="foot"/>
<child link="body"/><origin xyz="0 0 0.05"/><axis xyz="0 1 0"/>
<limit lower="-0.5" upper="0.5" effort="10" velocity="1"/></joint></robot>"""


def invoke(*args) -> Result:
    """click's result of ``sescid ARGS`` (arguments as text); an exception other than the
    command's exit is raised, and a traceback in the output fails."""
    res = CliRunner().invoke(cli, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    return res


def outcome(*args) -> tuple[int, str]:
    """Exit code and combined output of ``sescid ARGS`` (``invoke``)."""
    res = invoke(*args)
    return res.exit_code, res.output
