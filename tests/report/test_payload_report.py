"""The report of a payload fit shows the payload: its mass and CoM with their errors."""

from __future__ import annotations

from payload_gen import robot_with_payload

from sescid import Measurements, identify_payload, load_robot, simulate, write_report


def test_report_has_the_payload_section(tmp_path):
    op2 = load_robot("op2")
    truth = robot_with_payload(op2, tmp_path, "MP_ARM_LOW_R", 1.2, [0.08, 0.0, 0.0])
    sim = simulate(truth, n=8, noise=1e-3, seed=2)
    data = Measurements(q=sim.q, cop=sim.cop)
    fit = identify_payload(op2, data, "MP_ARM_LOW_R")
    write_report(fit, data, tmp_path / "rep")
    page = (tmp_path / "rep" / "report.html").read_text()
    assert "<h2>Payload on <code>MP_ARM_LOW_R</code></h2>" in page
    p = fit.payload
    assert p is not None
    assert f"{p.mass:.4f}" in page and f"{p.com[0] * 1e3:.1f}" in page
