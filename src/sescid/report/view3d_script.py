"""The 3-D view's inline script (plain JavaScript, no library): see ``view3d``."""

SCRIPT = r"""
(function () {
  var D = JSON.parse(document.getElementById("view3d-data").textContent);
  var cv = document.getElementById("view3d"), ctx = cv.getContext("2d");
  var slider = document.getElementById("view3d-pose");
  var label = document.getElementById("view3d-label");
  var W = cv.width, H = cv.height, AZ0 = 0.75, EL0 = 0.35, az = AZ0, el = EL0;
  var lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
  function grow(v) {
    for (var i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], v[i]); hi[i] = Math.max(hi[i], v[i]); }
  }
  D.seg.forEach(function (p) { p.forEach(function (s) { grow(s[0]); grow(s[1]); }); });
  D.origin.forEach(function (p) { p.forEach(grow); });
  if (D.sole) D.sole.forEach(grow);
  grow([lo[0], lo[1], D.floor]);
  var ctr = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
  var diag = Math.sqrt(Math.pow(hi[0] - lo[0], 2) + Math.pow(hi[1] - lo[1], 2) +
    Math.pow(hi[2] - lo[2], 2)) || 1;
  var scale = 1.1 * Math.min(W, H) / diag;
  var half = Math.max(hi[0] - lo[0], hi[1] - lo[1]) / 2 + 0.04 * diag;
  var step = [10, 20, 25, 50, 100, 200, 250, 500, 1000].filter(function (s) {
    return 2 * half / s <= 14; })[0] || 1000;
  function basis() {
    var ca = Math.cos(az), sa = Math.sin(az), ce = Math.cos(el), se = Math.sin(el);
    return { v: [ce * ca, ce * sa, se], r: [-sa, ca, 0], u: [-se * ca, -se * sa, ce] };
  }
  var B = basis();
  function dot3(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function proj(p) {
    var d = [p[0] - ctr[0], p[1] - ctr[1], p[2] - ctr[2]];
    return [W / 2 + scale * dot3(d, B.r), H / 2 - scale * dot3(d, B.u), dot3(d, B.v)];
  }
  function line(a, b, colour, width, dash) {
    var s = proj(a), t = proj(b);
    ctx.setLineDash(dash || []); ctx.strokeStyle = colour; ctx.lineWidth = width;
    ctx.beginPath(); ctx.moveTo(s[0], s[1]); ctx.lineTo(t[0], t[1]); ctx.stroke();
    ctx.setLineDash([]);
  }
  function poly(pts, fill, stroke) {
    ctx.beginPath();
    pts.forEach(function (p, i) {
      var s = proj(p);
      if (i) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]);
    });
    ctx.closePath();
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = 1.5; ctx.stroke(); }
  }
  function text(s, x, y, colour, align, size) {
    ctx.font = (size || 12) + "px sans-serif"; ctx.textAlign = align || "left";
    ctx.lineWidth = 3; ctx.strokeStyle = "rgba(255,255,255,0.85)"; ctx.strokeText(s, x, y);
    ctx.fillStyle = colour; ctx.fillText(s, x, y);
  }
  function disc(x, y, r, fill, stroke, width) {
    ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI);
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = width || 2; ctx.stroke(); }
  }
  function comMark(x, y, r) {
    disc(x, y, r, "#ffffff", null);
    for (var q = 0; q < 4; q += 2) {
      ctx.beginPath(); ctx.moveTo(x, y);
      ctx.arc(x, y, r, q * Math.PI / 2, (q + 1) * Math.PI / 2); ctx.closePath();
      ctx.fillStyle = "#c81e1e"; ctx.fill();
    }
    disc(x, y, r, null, "#c81e1e", 1.5);
  }
  function floorGrid() {
    var z = D.floor, x0 = ctr[0] - half, x1 = ctr[0] + half;
    var y0 = ctr[1] - half, y1 = ctr[1] + half;
    poly([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], "#f3f3ef", "#c9c9c0");
    for (var g = Math.ceil(x0 / step) * step; g <= x1; g += step)
      line([g, y0, z], [g, y1, z], g === 0 ? "#a0a098" : "#deded6", 1);
    for (g = Math.ceil(y0 / step) * step; g <= y1; g += step)
      line([x0, g, z], [x1, g, z], g === 0 ? "#a0a098" : "#deded6", 1);
  }
  function capsules(k) {
    var items = D.seg[k].map(function (s, i) {
      var a = proj(s[0]), b = proj(s[1]);
      return { a: a, b: b, d: (a[2] + b[2]) / 2, w: Math.max(2 * D.radius[i] * scale, 1.5),
        c: D.colours[Math.min(D.group[D.body[i]], D.colours.length - 1)] };
    });
    D.links.forEach(function (l) {
      var a = proj(D.origin[k][l[0]]), b = proj(D.origin[k][l[1]]);
      var colour = D.colours[Math.min(D.group[l[1]], D.colours.length - 1)];
      items.push({ a: a, b: b, d: (a[2] + b[2]) / 2, w: 5, c: colour, bone: true });
    });
    var dmin = Math.min.apply(null, items.map(function (t) { return t.d; }));
    var dmax = Math.max.apply(null, items.map(function (t) { return t.d; }));
    items.sort(function (u, v) { return u.d - v.d; });
    ctx.lineCap = "round";
    items.forEach(function (t) {
      var near = dmax > dmin ? (t.d - dmin) / (dmax - dmin) : 1;
      ctx.globalAlpha = t.bone ? 0.9 : 0.55 + 0.45 * near;
      ctx.strokeStyle = t.c; ctx.lineWidth = t.w;
      ctx.beginPath(); ctx.moveTo(t.a[0], t.a[1]); ctx.lineTo(t.b[0], t.b[1]); ctx.stroke();
    });
    ctx.globalAlpha = 1;
  }
  function shadow(k) {
    ctx.lineCap = "round"; ctx.globalAlpha = 0.12;
    D.seg[k].forEach(function (s, i) {
      line([s[0][0], s[0][1], D.floor], [s[1][0], s[1][1], D.floor], "#000000",
        Math.max(2 * D.radius[i] * scale, 1.5));
    });
    ctx.globalAlpha = 1;
  }
  function gizmo() {
    var ox = W - 60, oy = H - 50, names = ["x", "y", "z"];
    var cols = ["#d03030", "#30a030", "#3050d0"];
    for (var i = 0; i < 3; i++) {
      var e = [0, 0, 0]; e[i] = 1;
      var x = ox + 32 * dot3(e, B.r), y = oy - 32 * dot3(e, B.u);
      ctx.strokeStyle = cols[i]; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.moveTo(ox, oy); ctx.lineTo(x, y); ctx.stroke();
      text(names[i], x + 3, y + 4, cols[i], "left", 12);
    }
  }
  function legend() {
    var rows = D.held ? [["trunk (held)", D.colours[2]], ["limbs", D.colours[3]]] :
      [["support foot", D.colours[0]], ["support leg", D.colours[1]], ["trunk", D.colours[2]],
        ["other limbs", D.colours[3]]];
    var y = H - 12 - 16 * (rows.length + (D.cop ? 3 : 1));
    rows.forEach(function (r) {
      ctx.fillStyle = r[1]; ctx.fillRect(12, y - 9, 18, 10); text(r[0], 36, y, "#333"); y += 16;
    });
    comMark(21, y - 4, 6); text("CoM (identified)", 36, y, "#333"); y += 16;
    if (D.cop) {
      disc(21, y - 4, 4, "#1f4fd0", null); text("CoP measured", 36, y, "#333"); y += 16;
      disc(21, y - 4, 6, null, "#1a9a50", 2); text("CoP identified", 36, y, "#333");
    }
  }
  function inset(k) {
    var S = 170, x0 = W - S - 10, y0 = 10, pts = [];
    if (D.sole) D.sole.forEach(function (p) { pts.push(p); });
    pts.push(D.com[k]);
    if (D.cop) { pts.push(D.cop[k]); pts.push(D.cop_fit[k]); }
    var a = [1e9, 1e9], b = [-1e9, -1e9];
    pts.forEach(function (p) { for (var i = 0; i < 2; i++) {
      a[i] = Math.min(a[i], p[i]); b[i] = Math.max(b[i], p[i]); } });
    var span = Math.max(b[0] - a[0], b[1] - a[1], 20) * 1.15, s = (S - 30) / span;
    var cx = (a[0] + b[0]) / 2, cy = (a[1] + b[1]) / 2;
    function top(p) {
      return [x0 + S / 2 - s * (p[1] - cy), y0 + 18 + (S - 30) / 2 - s * (p[0] - cx)];
    }
    ctx.fillStyle = "rgba(255,255,255,0.92)"; ctx.fillRect(x0, y0, S, S);
    ctx.strokeStyle = "#999"; ctx.lineWidth = 1; ctx.strokeRect(x0, y0, S, S);
    text((D.sole ? "sole" : "CoM") + " from above (x up)", x0 + 6, y0 + 13, "#333", "left", 11);
    if (D.sole) {
      ctx.beginPath();
      D.sole.forEach(function (p, i) { var t = top(p); if (i) ctx.lineTo(t[0], t[1]);
        else ctx.moveTo(t[0], t[1]); });
      ctx.closePath(); ctx.fillStyle = "rgba(224,123,0,0.25)"; ctx.fill();
      ctx.strokeStyle = "#e07b00"; ctx.lineWidth = 1.5; ctx.stroke();
    }
    var c = top(D.com[k]); comMark(c[0], c[1], 5);
    if (D.cop) {
      var m = top(D.cop[k]), f = top(D.cop_fit[k]);
      disc(m[0], m[1], 3.5, "#1f4fd0", null); disc(f[0], f[1], 6, null, "#1a9a50", 2);
    }
    var bar = [10, 20, 50, 100, 200].filter(function (v) { return v * s >= 25; })[0] || 200;
    ctx.strokeStyle = "#333"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x0 + 8, y0 + S - 8); ctx.lineTo(x0 + 8 + bar * s, y0 + S - 8);
    ctx.stroke(); text(bar + " mm", x0 + 12 + bar * s, y0 + S - 4, "#333", "left", 11);
  }
  function draw() {
    var k = +slider.value;
    B = basis();
    ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, W, H);
    floorGrid();
    shadow(k);
    if (D.sole) {
      poly(D.sole.map(function (p) { return [p[0], p[1], D.floor]; }),
        "rgba(224,123,0,0.35)", "#e07b00");
      var s0 = D.sole.map(proj).reduce(function (a, b) { return b[0] > a[0] ? b : a; });
      text("support foot: " + D.support, s0[0] + 10, s0[1] + 4, "#a05000");
    }
    var c = D.com[k], g = [c[0], c[1], D.floor];
    line(c, g, "#c81e1e", 1.5, [5, 4]);
    var sg = proj(g); disc(sg[0], sg[1], 3, "#c81e1e", null);
    capsules(k);
    if (D.cop) {  // on top of the foot that stands on them
      var m = proj([D.cop[k][0], D.cop[k][1], D.floor]);
      var f = proj([D.cop_fit[k][0], D.cop_fit[k][1], D.floor]);
      disc(m[0], m[1], 4.5, "#1f4fd0", "#ffffff", 1); disc(f[0], f[1], 7, null, "#1a9a50", 2);
    }
    var sc = proj(c); comMark(sc[0], sc[1], 8);
    text(D.held ? "CoM z " + c[2].toFixed(0) + " mm" :
      "CoM " + (c[2] - D.floor).toFixed(0) + " mm above floor", sc[0] + 12, sc[1] - 8, "#a01010");
    text("pose " + D.labels[k] + "  (" + (k + 1) + " of " + D.labels.length + ")", 12, 22,
      "#222", "left", 15);
    text("grid " + step + " mm" + (D.held ? "; held: " + D.support : ""), 12, 40, "#777",
      "left", 11);
    legend(); gizmo(); inset(k);
    var info = "pose " + D.labels[k] + " (" + (k + 1) + "/" + D.labels.length + "): ";
    if (D.cop) {
      info += "CoP measured (" + D.cop[k][0].toFixed(2) + ", " + D.cop[k][1].toFixed(2) +
        ") mm, identified (" + D.cop_fit[k][0].toFixed(2) + ", " + D.cop_fit[k][1].toFixed(2) +
        ") mm; ";
    }
    label.textContent = info + "identified CoM (" + c[0].toFixed(1) + ", " + c[1].toFixed(1) +
      ", " + c[2].toFixed(1) + ") mm";
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
  cv.addEventListener("dblclick", function () { az = AZ0; el = EL0; draw(); });
  window.addEventListener("mouseup", function () { drag = null; });
  window.addEventListener("mousemove", function (e) {
    if (!drag) return;
    az = drag[2] - (e.clientX - drag[0]) * 0.01;
    el = Math.max(0.02, Math.min(1.55, drag[3] + (e.clientY - drag[1]) * 0.01));
    draw();
  });
  draw();
  if (m) { document.getElementById("view3d-section").scrollIntoView(); }
})();
"""
