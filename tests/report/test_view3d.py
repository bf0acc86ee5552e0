"""The session's live page (viser on the loopback) and the report's 3-D view, in a real browser."""

from __future__ import annotations

import re
import socket
import urllib.request

import matplotlib.image
import numpy as np
import pytest
from fitting import identify_ls
from op2_stance import stable_poses
from test_html import _browse, _chromium

from sescid.estimation import Measurements
from sescid.report import ReportOptions, scene_data, write_report
from sescid.report.view3d import SUPPORT_FOOT, SUPPORT_LEG, TRUNK
from sescid.session.loop import SessionStep

CHROMIUM = pytest.mark.skipif(_chromium() is None, reason="no chromium (apt-get install chromium)")


def _free_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def _live(op2):
    """A live view on a random loopback port, fed one planned and one measured pose."""
    pytest.importorskip("viser")
    from sescid.report.live import LiveView

    view = LiveView(op2, port=_free_port())
    q = stable_poses(op2, 1, seed=2)[0]
    step = SessionStep(
        "0",
        3,
        q,
        1.0,
        0.5,
        "measured",
        q_measured=q,
        cop=op2.cop(q[None])[0],
        cop_se=np.full(2, 1e-4),
        cop_std=0.002,
        rank=42,
        body_std=np.linspace(0.0, 0.005, len(op2.body_names)),
    )
    view.planned(0, "0", q, np.zeros(op2.nq))
    view.finished_pose(step, [step])
    return view


def test_live_page_serves_on_loopback_and_stops(op2):
    """The live page answers on 127.0.0.1 (no remote resource), then the server stops."""
    view = _live(op2)
    try:
        assert view.url.startswith("http://127.0.0.1:")
        page = urllib.request.urlopen(view.url, timeout=20).read().decode()
        assert "<html" in page.lower()
        assert not re.search(r'(src|href)="(https?:)?//', page)  # everything from localhost
    finally:
        view.close()
    with pytest.raises(OSError):
        urllib.request.urlopen(view.url, timeout=5)


def test_live_view_refuses_a_public_address(op2):
    """The live view serves localhost only."""
    pytest.importorskip("viser")
    from sescid.errors import OptionError
    from sescid.report.live import LiveView

    with pytest.raises(OptionError, match="localhost only"):
        LiveView(op2, host="0.0.0.0", port=_free_port())


def _coloured(img: np.ndarray) -> np.ndarray:
    """Mask of saturated (non-grey) pixels: the robot's colours, not background or grid."""
    rgb = img[..., :3].astype(float)
    return rgb.max(axis=2) - rgb.min(axis=2) > 0.15


@pytest.mark.slow
@CHROMIUM
def test_live_page_draws_the_robot_in_chromium(op2, tmp_path):
    """Headless Chromium renders the live scene: coloured robot pixels in the 3-D area."""
    view = _live(op2)
    counts = []
    try:  # the scene arrives over a websocket: a loaded machine may need another look
        for attempt in range(3):
            shot = tmp_path / f"live{attempt}.png"
            res = _browse(
                _chromium(),
                view.url,
                "--window-size=1000,800",
                "--virtual-time-budget=5000",
                f"--screenshot={shot}",
            )
            assert res.returncode == 0, res.stderr[-2000:]
            img = matplotlib.image.imread(shot)
            # below the notice, left of the control panel
            counts.append(int(_coloured(img[200:750, 150:650]).sum()))
            if counts[-1] > 2000:
                break
    finally:
        view.close()
    assert max(counts) > 2000, counts


@pytest.fixture(scope="module")
def report(op2, tmp_path_factory):
    """A report on 12 measured poses (noise-free CoPs, LS fit on 48)."""
    q = stable_poses(op2, 48, seed=0)
    fit = identify_ls(op2, q, op2.cop(q))
    out = tmp_path_factory.mktemp("rep3d")
    res = write_report(
        fit, Measurements(q=q[:12], cop=op2.cop(q[:12])), out, ReportOptions(n_side=2)
    )
    return res.html


def test_report_embeds_the_3d_scene(report, op2):
    """The page carries the scene JSON for every pose and no outside resource."""
    page = report.read_text()
    data = re.search(r'<script type="application/json" id="view3d-data">(.*?)</script>', page, re.S)
    import json

    scene = json.loads(data.group(1))
    assert len(scene["seg"]) == 12 and len(scene["com"]) == 12
    assert not re.search(r'(src|href)="(?!data:)', page)


@CHROMIUM
def test_report_3d_view_changes_with_the_slider(report, tmp_path):
    """In Chromium the canvas draws each pose (its own ink count) and the picture changes."""
    binary, url = _chromium(), report.resolve().as_uri()
    ink, shots = [], []
    for k in (0, 11):
        dom = _browse(binary, f"{url}#view3d={k}", "--dump-dom")
        assert dom.returncode == 0, dom.stderr[-2000:]
        m = re.search(r'<canvas id="view3d"[^>]*data-pose="(\d+)" data-ink="(\d+)"', dom.stdout)
        assert m and int(m.group(1)) == k
        ink.append(int(m.group(2)))
        shot = tmp_path / f"p{k}.png"
        res = _browse(binary, f"{url}#view3d={k}", "--window-size=900,900", f"--screenshot={shot}")
        assert res.returncode == 0
        shots.append(_coloured(matplotlib.image.imread(shot)))
    assert min(ink) > 20_000  # a robot, not an empty canvas (760 × 560 px)
    assert ink[0] != ink[1]
    a, b = shots
    assert a.sum() > 20_000 and b.sum() > 20_000  # the robot is on screen (scrolled into view)
    assert (a ^ b).sum() > 1000  # and it moved between the two poses


def test_scene_marks_the_support_leg_and_orders_the_sole(op2):
    """Limbs of the OP2 (right sole support): the support foot, the right leg up to the trunk
    (MP_BODY), the trunk, the other limbs; the sole's corners go round its rectangle."""
    q = stable_poses(op2, 3, seed=1)
    scene = scene_data(op2, q, op2.com(q), op2.cop(q), op2.cop(q), ["a", "b", "c"])
    group = dict(zip(op2.body_names, scene["group"], strict=True))
    leg = ["MP_ANKLE1_R", "MP_TIBIA_R", "MP_THIGH2_R", "MP_THIGH1_R", "MP_PELVIS_R"]
    assert group["MP_ANKLE2_R"] == SUPPORT_FOOT and group["MP_BODY"] == TRUNK
    assert all(group[b] == SUPPORT_LEG for b in leg)
    others = {b: g for b, g in group.items() if b not in [*leg, "MP_ANKLE2_R", "MP_BODY"]}
    assert min(others.values()) > TRUNK
    assert group["MP_ARM_LOW_R"] == group["MP_SHOULDER_R"] != group["MP_SHOULDER_L"]
    corners = np.array(scene["sole"])[:, :2]
    edges = np.roll(corners, -1, axis=0) - corners
    area = 0.5 * abs(np.sum(corners[:, 0] * np.roll(corners[:, 1], -1) -
                            np.roll(corners[:, 0], -1) * corners[:, 1]))  # fmt: skip
    size = op2.sole.size
    assert area == pytest.approx(size[0] * size[1] * 1e6, rel=1e-3)  # a rectangle, not a bow tie
    assert np.allclose(np.sum(edges[:-1] * edges[1:], axis=1), 0, atol=1e-6)
    assert len(scene["origin"]) == 3 and len(scene["origin"][0]) == len(op2.body_names)
    assert scene["held"] is False and scene["floor"] == 0.0


def test_scene_of_feet_only_collision_keeps_the_skeleton(tmp_path):
    """An MJCF humanoid whose only collision geometry is its feet: the capsules are the feet's,
    the skeleton links every body (so the limbs are drawn); a held trunk (gantry) has no sole
    and a reference plane under its lowest point."""
    from humanoid_mjcf_gen import write_humanoid

    import sescid

    robot = sescid.load_robot(write_humanoid(tmp_path / "h"), "r_sole")
    q = np.zeros((2, robot.nq))
    scene = scene_data(robot, q, robot.com(q), None, None, ["0", "1"])
    feet = {robot.body_names[b] for b in scene["body"]}
    assert feet == {"r_foot", "l_foot"}
    assert len(scene["links"]) == len(robot.body_names) - 1 and scene["cop"] is None
    held = sescid.load_robot(write_humanoid(tmp_path / "g"), "pelvis")
    scene = scene_data(held, q, held.com(q), None, None, ["0", "1"])
    lowest = min(p[2] for pose in scene["origin"] for p in pose)
    assert scene["held"] and scene["sole"] is None and scene["floor"] < lowest
