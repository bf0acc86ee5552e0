"""The live view of a guided session: a loopback web page served by viser (the ``view`` extra).

Shows the robot (capsules of its collision shapes) at its current pose, the next pose as a
ghost, the CoM (and its ground projection) and the measured and predicted CoP on the support
sole with the stability box, the convergence curve (predicted RMS CoP std per measured pose)
and the bodies coloured by how uncertain their SESC vectors still are (green: within 10 % of the
prior scale, red: as uncertain as the prior). Served on 127.0.0.1 only; ``close`` stops it
(after an optional bounded linger). A session runs the same without it.
"""

from __future__ import annotations

import math
import time

import numpy as np

from sescid.errors import MissingExtraError, OptionError
from sescid.planning import collision_capsules, cop_half_extents
from sescid.robot import Robot
from sescid.session.loop import BODY_PRIOR_SCALE, SessionObserver, SessionStep

LOOPBACK = ("127.0.0.1", "localhost", "::1")
MAX_LINGER = 3600.0  #: s, the longest a finished view keeps serving


def _viser():
    try:
        import viser
    except ImportError:  # pragma: no cover - depends on the environment
        raise MissingExtraError("the live view", "view") from None
    return viser


def uncertainty_colors(body_std: np.ndarray | None, n: int) -> np.ndarray:
    """(N, 3) RGB in 0..1 per body: green (certain) → red (as uncertain as the prior)."""
    if body_std is None:
        u = np.ones(n)
    else:
        u = np.clip(np.asarray(body_std) / BODY_PRIOR_SCALE, 0.0, 1.0)
    return np.column_stack([0.2 + 0.75 * u, 0.8 - 0.6 * u, 0.25 * np.ones(n)])


class LiveView(SessionObserver):
    """A viser server on the loopback interface, updated by the session's observer hooks."""

    def __init__(self, robot: Robot, host: str = "127.0.0.1", port: int = 8080):
        if host not in LOOPBACK:
            raise OptionError("host", f"the live view serves localhost only, not '{host}'")
        viser = _viser()
        self.robot = robot
        self.caps = collision_capsules(robot)
        self.half = cop_half_extents(robot)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.url = f"http://{host}:{self.server.get_port()}"
        sc, gui = self.server.scene, self.server.gui
        sc.set_up_direction("+z")
        cam = self.server.initial_camera
        cam.position = (0.45, -0.55, 0.4)
        cam.look_at = (0.0, 0.0, 0.13)
        sc.add_grid("/ground", width=0.6, height=0.6, cell_size=0.05)
        hx, hy = self.half
        box = np.array([[hx, hy, 0], [hx, -hy, 0], [-hx, -hy, 0], [-hx, hy, 0]], dtype=float)
        sc.add_line_segments(
            "/support_box",
            np.stack([box, np.roll(box, -1, axis=0)], axis=1),
            (40, 40, 200),
            thickness=0.002,
        )
        self.status = gui.add_markdown("**sescid session**: planning…")
        self.curve = gui.add_uplot(
            data=(np.zeros(1), np.zeros(1)),
            series=({"label": "measured poses"}, {"label": "CoP std [mm]", "stroke": "red"}),
            title="predicted RMS CoP std",
            scales={"x": {"time": False}},
            aspect=1.5,
        )
        self._body_std: np.ndarray | None = None
        self._nodes: dict = {}
        self._draw("/robot/current", np.zeros(robot.nq), None, 1.0)

    # --- drawing ----------------------------------------------------------------------------
    def _segments(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rot, org = self.robot.forward(q[None])
        w0, w1 = self.caps.world(rot, org)
        return np.stack([w0[0], w1[0]], axis=1), self.caps.radius

    def _draw(self, name: str, q: np.ndarray, body_std, opacity: float) -> None:
        seg, rad = self._segments(q)
        col = uncertainty_colors(body_std, len(self.robot.body_names))[self.caps.body]
        if opacity < 1:  # the next pose: a pale ghost
            col = 0.6 + 0.4 * col
        rgb = np.repeat((col * 255).astype(np.uint8)[:, None, :], 2, axis=1)
        # one line segment per capsule, as thick as the capsule (world units)
        self._nodes[name] = self.server.scene.add_line_segments(
            name, seg, rgb, thickness=float(2 * np.mean(rad)), thickness_units="world"
        )
        com = self.robot.com(q[None])[0]
        if opacity == 1:
            sc = self.server.scene
            sc.add_icosphere("/com", radius=0.008, color=(220, 30, 30), position=tuple(com))
            sc.add_line_segments(
                "/com_drop",
                np.array([[com, [com[0], com[1], 0.0]]]),
                (220, 30, 30),
                thickness=0.001,
            )

    # --- observer hooks ---------------------------------------------------------------------
    def planned(self, step_no: int, pose: str, q: np.ndarray, q_current: np.ndarray) -> None:
        """Show the next pose planned after ``step_no`` (ghost) beside the current one."""
        self._draw("/robot/next", q, self._body_std, 0.4)
        self.status.content = f"**pose {pose}** commanded (step {step_no + 1}); waiting to settle"

    def finished_pose(self, step: SessionStep, steps: list[SessionStep]) -> None:
        """Update the view after a pose was measured (or skipped)."""
        sc = self.server.scene
        if step.status != "measured":
            self.status.content = f"**pose {step.pose} skipped**: {step.reason}"
            return
        assert step.q_measured is not None and step.cop is not None
        self._body_std = step.body_std
        ghost = self._nodes.pop("/robot/next", None)
        if ghost is not None:  # the next pose is now the current one
            ghost.remove()
        self._draw("/robot/current", step.q_measured, step.body_std, 1.0)
        sc.add_icosphere(
            "/cop/measured", radius=0.005, color=(30, 90, 230), position=(*step.cop, 0.0)
        )
        if step.cop_predicted is not None:
            sc.add_icosphere(
                "/cop/predicted",
                radius=0.004,
                color=(30, 200, 90),
                position=(*step.cop_predicted, 0.0),
            )
        measured = [s for s in steps if s.status == "measured" and math.isfinite(s.cop_std)]
        if measured:
            x = np.arange(1, len(measured) + 1, dtype=float)
            y = np.array([s.cop_std * 1e3 for s in measured])
            self.curve.data = (x, y)
        std = "not yet" if not math.isfinite(step.cop_std) else f"{step.cop_std * 1e3:.3f} mm"
        worst = ""
        if step.body_std is not None:
            i = int(np.argmax(step.body_std))
            worst = f"; most uncertain body {self.robot.body_names[i]}"
        self.status.content = (
            f"**pose {step.pose}** measured: CoP ({step.cop[0] * 1e3:.2f}, "
            f"{step.cop[1] * 1e3:.2f}) mm; predicted CoP std {std}, rank {step.rank}{worst}"
            + (" — **converged**" if step.converged else "")
        )

    def stopped(self, result) -> None:
        """Show why the session ended."""
        self.status.content = f"**session ended**: {result.stop_reason}"

    def close(self, linger: float = 0.0) -> None:
        """Stop serving, after at most ``linger`` seconds (bounded by ``MAX_LINGER``)."""
        if linger > 0:
            time.sleep(min(linger, MAX_LINGER))
        self.server.stop()
