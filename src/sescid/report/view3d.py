"""A standalone 3-D view for the HTML report: the robot at the measured poses, with a slider.

No library, no network: the page carries the scene as JSON (capsule ends per pose in the
support frame, mm) and a small inline script draws it on a ``<canvas>`` — each collision capsule
is a thick line with round caps in an orthographic view (painter's order), the support sole and
the stability box on the ground, the identified CoM (red) with its ground projection, the
measured CoP (blue dot) and the identified model's CoP (green ring). A slider picks the pose;
dragging the canvas turns the view. ``#view3d=K`` in the address opens pose K (scrolled into
view). After every draw the canvas reports its pose and its count of non-background pixels in
``data-pose`` and ``data-ink`` (the page's own check, read by the tests).
"""

from __future__ import annotations

import html
import json

import numpy as np

from sescid.planning import collision_capsules, cop_half_extents


def scene_data(robot, q, com, cop, cop_fit, labels) -> dict:
    """The view's JSON: per pose capsule segments, CoM, CoPs (mm, support frame)."""
    q = np.asarray(q, dtype=float)
    caps = collision_capsules(robot)
    rot, org = robot.forward(q)
    w0, w1 = caps.world(rot, org)
    seg = np.round(np.stack([w0, w1], axis=2) * 1e3, 1)  # (n, C, 2, 3) mm
    half = cop_half_extents(robot)
    sole = robot.profile.sole_size
    mm = 1e3
    return {
        "labels": [str(s) for s in labels],
        "body": caps.body.tolist(),
        "n_bodies": len(robot.body_names),
        "radius": np.round(caps.radius * mm, 1).tolist(),
        "seg": seg.tolist(),
        "com": np.round(np.asarray(com) * mm, 2).tolist(),
        "cop": np.round(np.asarray(cop) * mm, 2).tolist(),
        "cop_fit": np.round(np.asarray(cop_fit) * mm, 2).tolist(),
        "box": np.round(half * mm, 2).tolist(),
        "sole": None if sole is None else [float(sole[0]) * mm / 2, float(sole[1]) * mm / 2],
    }


_SCRIPT = r"""
(function () {
  var D = JSON.parse(document.getElementById("view3d-data").textContent);
  var cv = document.getElementById("view3d"), ctx = cv.getContext("2d");
  var slider = document.getElementById("view3d-pose");
  var label = document.getElementById("view3d-label");
  var az = -0.8, el = 0.4, W = cv.width, H = cv.height;
  var lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
  D.seg.forEach(function (p) { p.forEach(function (s) { s.forEach(function (v) {
    for (var i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], v[i]); hi[i] = Math.max(hi[i], v[i]); }
  }); }); });
  var ext = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1);
  var scale = 0.8 * Math.min(W, H) / ext, mid = (lo[2] + hi[2]) / 2;
  function proj(p) {
    var ca = Math.cos(az), sa = Math.sin(az), ce = Math.cos(el), se = Math.sin(el);
    var x = ca * p[0] - sa * p[1], y = sa * p[0] + ca * p[1], z = p[2] - mid;
    return [W / 2 + scale * x, H / 2 - scale * (y * se + z * ce), y * ce - z * se];
  }
  function colour(b, shade) {
    var h = (b * 137.5) % 360;
    return "hsl(" + h + ",45%," + Math.round(35 + 30 * shade) + "%)";
  }
  function poly(pts, fill, stroke, dash) {
    ctx.beginPath();
    pts.forEach(function (p, i) {
      var s = proj(p);
      if (i) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]);
    });
    ctx.closePath();
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    ctx.setLineDash(dash || []); ctx.strokeStyle = stroke; ctx.lineWidth = 1; ctx.stroke();
    ctx.setLineDash([]);
  }
  function rect(hx, hy) { return [[hx, hy, 0], [hx, -hy, 0], [-hx, -hy, 0], [-hx, hy, 0]]; }
  function dot(p, r, fill, stroke) {
    var s = proj(p);
    ctx.beginPath(); ctx.arc(s[0], s[1], r, 0, 2 * Math.PI);
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = 2; ctx.stroke(); }
  }
  function draw() {
    var k = +slider.value;
    ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, W, H);
    if (D.sole) poly(rect(D.sole[0], D.sole[1]), "#dddddd", "#888888");
    poly(rect(D.box[0], D.box[1]), null, "#3050c0", [4, 3]);
    var items = D.seg[k].map(function (s, i) {
      var a = proj(s[0]), b = proj(s[1]);
      return { a: a, b: b, d: (a[2] + b[2]) / 2, i: i };
    });
    var dmin = Math.min.apply(null, items.map(function (t) { return t.d; }));
    var dmax = Math.max.apply(null, items.map(function (t) { return t.d; }));
    items.sort(function (u, v) { return v.d - u.d; });
    ctx.lineCap = "round";
    items.forEach(function (t) {
      var shade = dmax > dmin ? (dmax - t.d) / (dmax - dmin) : 0.5;
      ctx.strokeStyle = colour(D.body[t.i], shade);
      ctx.lineWidth = Math.max(2 * D.radius[t.i] * scale, 1);
      ctx.beginPath(); ctx.moveTo(t.a[0], t.a[1]); ctx.lineTo(t.b[0], t.b[1]); ctx.stroke();
    });
    var c = D.com[k], g = [c[0], c[1], 0];
    var sc = proj(c), sg = proj(g);
    ctx.setLineDash([5, 4]); ctx.strokeStyle = "#d02020"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(sc[0], sc[1]); ctx.lineTo(sg[0], sg[1]); ctx.stroke();
    ctx.setLineDash([]);
    dot(c, 6, "#d02020", "#ffffff");
    dot(g, 3, "#d02020", null);
    dot([D.cop[k][0], D.cop[k][1], 0], 5, "#2050e0", null);
    dot([D.cop_fit[k][0], D.cop_fit[k][1], 0], 7, null, "#20a050");
    label.textContent = "pose " + D.labels[k] + " (" + (k + 1) + "/" + D.labels.length +
      "): CoP measured (" + D.cop[k][0].toFixed(2) + ", " + D.cop[k][1].toFixed(2) +
      ") mm, identified (" + D.cop_fit[k][0].toFixed(2) + ", " + D.cop_fit[k][1].toFixed(2) +
      ") mm; identified CoM height " + c[2].toFixed(1) + " mm";
    var px = ctx.getImageData(0, 0, W, H).data, ink = 0;
    for (var i = 0; i < px.length; i += 4) {
      if (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) ink++;
    }
    cv.setAttribute("data-pose", String(k));
    cv.setAttribute("data-ink", String(ink));
  }
  var m = /view3d=(\d+)/.exec(location.hash);
  if (m) { slider.value = Math.min(+m[1], D.labels.length - 1); }
  slider.addEventListener("input", draw);
  var drag = null;
  cv.addEventListener("mousedown", function (e) { drag = [e.clientX, e.clientY, az, el]; });
  window.addEventListener("mouseup", function () { drag = null; });
  window.addEventListener("mousemove", function (e) {
    if (!drag) return;
    az = drag[2] + (e.clientX - drag[0]) * 0.01;
    el = Math.max(-1.5, Math.min(1.5, drag[3] + (e.clientY - drag[1]) * 0.01));
    draw();
  });
  draw();
  if (m) { document.getElementById("view3d-section").scrollIntoView(); }
})();
"""


def view3d_html(data: dict, width: int = 760, height: int = 560) -> str:
    """The view's HTML section: canvas, slider, label, the scene JSON and the inline script."""
    n = len(data["labels"])
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return f"""<section id="view3d-section">
<h2>3-D view of the measured poses</h2>
<p>Collision capsules at each measured pose (support frame); red: identified CoM and its ground
projection; blue dot: measured CoP; green ring: identified model's CoP; grey: support sole;
dashed: stability box. Slide to change the pose, drag the picture to turn it.</p>
<input type="range" id="view3d-pose" min="0" max="{n - 1}" value="0" step="1"
 style="width:{width}px" aria-label="pose">
<div id="view3d-label" style="font-size:0.9em">{html.escape(data["labels"][0])}</div>
<canvas id="view3d" width="{width}" height="{height}" style="border:1px solid #ccc;cursor:grab">
</canvas>
<script type="application/json" id="view3d-data">{payload}</script>
<script>{_SCRIPT}</script>
</section>"""
