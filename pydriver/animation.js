// The cable animation of report.html (pydriver/animation.py embeds this file and the data).
//
// Hand-written on purpose: the report must open offline as one file (no CDN, no external
// script), and no plotting library that draws interactive 3-D fits in one file under the
// report's 5 MB budget (plotly.js alone is 3.5 MB minified, three.js 0.6 MB before any
// controls).  What is needed is small: an orthographic projection of a few dozen line
// segments, painter's ordering by depth, a colour map, mouse-drag rotation and a slider.
//
// Data (JSON in <script id="cable-data">): p[frame] = flat joint points in units of unit_m,
// strain[frame][joint], damage[joint] or null, hub (rotor centre) or null, axis = the slider's
// quantity per frame, before[frame] = a design run's start design (points like p) or null.  World z is up; the view turns about z (drag left/right) and tilts
// (drag up/down); equal scale on every axis (to scale).
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("cable-data").textContent);
  const canvas = document.getElementById("cable-canvas");
  const ctx = canvas.getContext("2d");
  const slider = document.getElementById("cable-slider");
  const label = document.getElementById("cable-label");
  const play = document.getElementById("cable-play");
  const colour = document.getElementById("cable-colour");
  const speed = document.getElementById("cable-speed");
  const n = D.n, F = D.p.length, u = D.unit_m;

  // Viridis, 9 stops (matplotlib's colour map, perceptually uniform, readable in grey).
  const VIR = [[68, 1, 84], [71, 44, 122], [59, 81, 139], [44, 113, 142], [33, 144, 141],
               [39, 173, 129], [92, 200, 99], [170, 220, 50], [253, 231, 37]];
  function cmap(x) {
    if (!(x >= 0)) return "rgb(170,170,170)";          // no value (a joint without damage)
    x = Math.min(1, x) * (VIR.length - 1);
    const i = Math.min(VIR.length - 2, Math.floor(x)), f = x - i, a = VIR[i], b = VIR[i + 1];
    return "rgb(" + [0, 1, 2].map(k => Math.round(a[k] + f * (b[k] - a[k]))).join(",") + ")";
  }

  // Colour scales: strain linear from 0 to the largest over all frames; damage logarithmic
  // over the joints that take damage.
  const scales = {
    strain: { title: "jacket strain [%]", lo: 0, hi: D.strain_max || 1, log: false, pct: true,
              value: (k, j) => D.strain[k][j] },
    damage: null,
  };
  if (D.damage) {
    const pos = D.damage.filter(v => v > 0);
    const lo = pos.length ? Math.log10(Math.min(...pos)) : 0, hi = pos.length ? Math.log10(Math.max(...pos)) : 1;
    scales.damage = { title: "damage per flight hour [1/h]", lo: lo, hi: hi > lo ? hi : lo + 1, log: true,
                      value: (k, j) => D.damage[j] };
  } else {
    colour.querySelector("option[value=damage]").disabled = true;
  }

  // Scene centre over every frame (the view does not jump while playing).
  const all = [];
  for (const f of D.p) for (let i = 0; i < f.length; i += 3) all.push([f[i] * u, f[i + 1] * u, f[i + 2] * u]);
  if (D.before) for (const f of D.before) for (let i = 0; i < f.length; i += 3) all.push([f[i] * u, f[i + 1] * u, f[i + 2] * u]);
  const hub = D.hub ? D.hub.map(v => v * u) : null;
  const axisLen = D.hub ? 0.25 * Math.max(...[0, 1, 2].map(c => Math.max(...all.map(p => p[c])) - Math.min(...all.map(p => p[c])))) : 0;
  if (hub) { all.push(hub); all.push([hub[0], hub[1], hub[2] + axisLen]); }
  const lo3 = [0, 1, 2].map(c => Math.min(...all.map(p => p[c])));
  const hi3 = [0, 1, 2].map(c => Math.max(...all.map(p => p[c])));
  const centre = [0, 1, 2].map(c => 0.5 * (lo3[c] + hi3[c]));

  // A link may choose the start: report.html#frame=90&view=-120,30&colour=damage (frame index;
  // yaw, pitch [deg]; strain or damage).
  const hash = new URLSearchParams(location.hash.slice(1));
  const v = (hash.get("view") || "").split(",").map(Number);
  if (v.length === 2 && v.every(isFinite)) D.view = v;
  const view0 = { yaw: D.view[0] * Math.PI / 180, pitch: D.view[1] * Math.PI / 180, zoom: 1 };
  let view = Object.assign({}, view0), frame = Math.min(F - 1, Math.max(0, parseInt(hash.get("frame"), 10) || 0));
  let playing = false, last = 0, timer = null;
  let fit = null;                            // projected extent in the first view: fills the canvas

  function project(p) {                      // -> [screen x, screen y (up), depth (into screen)]
    const x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
    const cy = Math.cos(view.yaw), sy = Math.sin(view.yaw), cp = Math.cos(view.pitch), sp = Math.sin(view.pitch);
    const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
    return [x1, sp * y1 + cp * z, cp * y1 - sp * z];
  }

  let W = 0, H = 0, S = 1, ox = 0, oy = 0;
  function resize() {
    const r = window.devicePixelRatio || 1, w = canvas.clientWidth, h = canvas.clientHeight;
    canvas.width = Math.round(w * r); canvas.height = Math.round(h * r);
    ctx.setTransform(r, 0, 0, r, 0, 0);
    W = w; H = h;
  }
  function toScreen(q) { return [ox + S * q[0], oy - S * q[1]]; }

  function text(s, x, y, align, size, col) {
    ctx.font = (size || 12) + "px sans-serif"; ctx.textAlign = align || "left";
    ctx.fillStyle = col || "#222"; ctx.fillText(s, x, y);
  }
  function fmt(v) { return Math.abs(v) >= 1e-2 && Math.abs(v) < 1e3 ? v.toPrecision(3) : v.toExponential(1); }

  function colourBar(sc) {
    const x = W - 70, y0 = 40, h = H - 110, w = 16;
    for (let i = 0; i < h; i++) { ctx.fillStyle = cmap(1 - i / h); ctx.fillRect(x, y0 + i, w, 1.5); }
    ctx.strokeStyle = "#444"; ctx.lineWidth = 1; ctx.strokeRect(x, y0, w, h);
    for (let i = 0; i <= 4; i++) {
      const f = i / 4, v = sc.lo + f * (sc.hi - sc.lo), yy = y0 + h * (1 - f);
      const s = sc.log ? Math.pow(10, v).toExponential(1) : sc.pct ? (100 * v).toFixed(2) : fmt(v);
      ctx.beginPath(); ctx.moveTo(x + w, yy); ctx.lineTo(x + w + 4, yy); ctx.stroke();
      text(s, x + w + 6, yy + 4, "left", 11);
    }
    ctx.save(); ctx.translate(x - 8, y0 + h / 2); ctx.rotate(-Math.PI / 2);
    text(sc.title, 0, 0, "center", 12); ctx.restore();
  }

  function marker(kind, q, name) {
    const [x, y] = toScreen(q);
    ctx.fillStyle = "#222"; ctx.strokeStyle = "#222"; ctx.lineWidth = 1.5;
    ctx.beginPath();
    if (kind === "square") ctx.rect(x - 6, y - 6, 12, 12);
    else if (kind === "triangle") { ctx.moveTo(x, y - 8); ctx.lineTo(x + 7, y + 5); ctx.lineTo(x - 7, y + 5); ctx.closePath(); }
    else { ctx.arc(x, y, 6, 0, 2 * Math.PI); }
    if (kind === "hub") { ctx.fillStyle = "#fff"; ctx.fill(); ctx.stroke(); ctx.beginPath(); ctx.arc(x, y, 2, 0, 7); ctx.fillStyle = "#222"; ctx.fill(); }
    else ctx.fill();
    ctx.lineWidth = 3; ctx.strokeStyle = "rgba(251,251,253,0.9)"; ctx.font = "12px sans-serif";
    ctx.textAlign = "left"; ctx.strokeText(name, x + 12, y + 16);          // a halo keeps it legible
    text(name, x + 12, y + 16, "left", 12, "#222");
  }

  function draw() {
    const sc = scales[colour.value] || scales.strain;
    ctx.clearRect(0, 0, W, H);
    ctx.fillStyle = "#fbfbfd"; ctx.fillRect(0, 0, W, H);
    const plotW = W - 150, plotH = H - 70;
    if (!fit) {
      const q = all.map(project), xs = q.map(v => v[0]), ys = q.map(v => v[1]);
      const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
      fit = { s: 0.92 * Math.min(plotW / Math.max(x1 - x0, 1e-9), plotH / Math.max(y1 - y0, 1e-9)),
              cx: 0.5 * (x0 + x1), cy: 0.5 * (y0 + y1) };
    }
    S = view.zoom * fit.s;
    ox = 10 + plotW / 2 - S * fit.cx; oy = 35 + plotH / 2 + S * fit.cy;
    const f = D.p[frame], pts = [];
    for (let i = 0; i <= n; i++) pts.push([f[3 * i] * u, f[3 * i + 1] * u, f[3 * i + 2] * u]);
    const pr = pts.map(project);
    // Path of the tip over all frames (clamp B moving with the blade), faint.
    ctx.strokeStyle = "rgba(120,120,160,0.35)"; ctx.lineWidth = 1; ctx.beginPath();
    D.p.forEach((g, k) => { const [x, y] = toScreen(project([g[3 * n] * u, g[3 * n + 1] * u, g[3 * n + 2] * u]));
                            if (k) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    if (D.periodic) ctx.closePath();
    ctx.stroke();
    if (hub) {                               // rotor axis (z of the hub frame) through the hub
      const a = toScreen(project([hub[0], hub[1], hub[2] - axisLen])), b = toScreen(project([hub[0], hub[1], hub[2] + axisLen]));
      ctx.setLineDash([6, 4]); ctx.strokeStyle = "#777"; ctx.beginPath(); ctx.moveTo(...a); ctx.lineTo(...b); ctx.stroke();
      ctx.setLineDash([]);
    }
    if (D.before) {                          // a design's start design, grey, beneath the optimum
      const g = D.before[frame];
      ctx.strokeStyle = "rgba(110,110,110,0.55)"; ctx.lineCap = "round";
      ctx.lineWidth = Math.max(2, Math.min(7, S * D.diameter_m)); ctx.beginPath();
      for (let i = 0; i <= n; i++) {
        const [x, y] = toScreen(project([g[3 * i] * u, g[3 * i + 1] * u, g[3 * i + 2] * u]));
        if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y);
      }
      ctx.stroke();
      text("grey: before (the deck's design); colour: after (the optimum)", 12, 38, "left", 12, "#555");
    }
    // Half-bodies, far ones first: body j's first half in joint j's colour, its second half
    // in joint j+1's (the last body's second half in joint n's: the tip is no joint).
    const segs = [];
    for (let j = 0; j < n; j++) {
      const m = pr[j].map((v, c) => 0.5 * (v + pr[j + 1][c]));
      segs.push([pr[j], m, j, j]);
      segs.push([m, pr[j + 1], Math.min(j + 1, n - 1), j]);
    }
    segs.sort((a, b) => (b[0][2] + b[1][2]) - (a[0][2] + a[1][2]));
    ctx.lineCap = "round"; ctx.lineWidth = Math.max(3, Math.min(9, S * D.diameter_m));
    for (const [a, b, jc] of segs) {
      const v = sc.value(frame, jc);
      const x = sc.log ? (v > 0 ? (Math.log10(v) - sc.lo) / (sc.hi - sc.lo) : -1) : (v - sc.lo) / (sc.hi - sc.lo);
      ctx.strokeStyle = cmap(x);
      ctx.beginPath(); ctx.moveTo(...toScreen(a)); ctx.lineTo(...toScreen(b)); ctx.stroke();
    }
    marker("square", pr[0], "A (clamp)");
    marker("triangle", pr[n], D.clamp_b ? "B (clamp)" : "tip");
    if (hub) marker("hub", project(hub), "hub (rotor centre)");
    colourBar(sc);
    triad(); scaleBar();
    const ax = D.axis;
    text(`${ax.label} ${ax.values[frame].toFixed(ax.digits)} ${ax.unit}   (frame ${frame + 1} of ${F})`, 12, 20, "left", 13);
    text("drag to turn, wheel to zoom, double-click to reset", 12, H - 10, "left", 11, "#666");
    label.textContent = `${ax.label} = ${ax.values[frame].toFixed(ax.digits)} ${ax.unit}`;
  }

  function triad() {
    const x0 = 45, y0 = H - 50, L = 28;
    ["x", "y", "z"].forEach((name, c) => {
      const e = [0, 0, 0]; e[c] = 1;
      const q = project([centre[0] + e[0], centre[1] + e[1], centre[2] + e[2]]);
      ctx.strokeStyle = ["#c33", "#3a3", "#33c"][c]; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x0 + L * q[0], y0 - L * q[1]); ctx.stroke();
      text(name, x0 + (L + 8) * q[0], y0 - (L + 8) * q[1] + 4, "center", 12, ctx.strokeStyle);
    });
  }

  function scaleBar() {
    const target = 120 / S;                  // a round length near 120 px
    const p10 = Math.pow(10, Math.floor(Math.log10(target)));
    const len = [1, 2, 5, 10].map(k => k * p10).filter(v => v <= target).pop();
    const x1 = W - 150, x0 = x1 - len * S, y = H - 14;
    ctx.strokeStyle = "#222"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x0, y - 4); ctx.lineTo(x0, y); ctx.lineTo(x1, y); ctx.lineTo(x1, y - 4); ctx.stroke();
    text((len >= 0.1 ? len.toFixed(len >= 1 ? 0 : 1) + " m" : (1000 * len).toFixed(0) + " mm"), (x0 + x1) / 2, y - 6, "center", 11);
  }

  // Timer-driven, not requestAnimationFrame: a frame lasts D.frame_ms (tens of ms), so a timer
  // is as smooth, and timers advance with a headless browser's virtual time, whereas animation
  // frames are not produced there when the machine is loaded (the report's test looks at it so).
  function tick() {
    if (!playing) return;
    const now = performance.now(), dt = D.frame_ms / parseFloat(speed.value);
    if (now - last >= dt) {
      const step = Math.max(1, Math.floor((now - last) / dt));
      frame = (frame + step) % F; last += step * dt; slider.value = frame; draw();
    }
    timer = setTimeout(tick, Math.max(0, last + dt - performance.now()));
  }

  play.addEventListener("click", () => {
    playing = !playing; play.textContent = playing ? "pause" : "play";
    clearTimeout(timer);                     // one timer chain, however often it is toggled
    if (playing) { last = performance.now(); timer = setTimeout(tick, 0); }
  });
  slider.max = F - 1;
  slider.addEventListener("input", () => { frame = parseInt(slider.value, 10); draw(); });
  colour.addEventListener("change", draw);
  let drag = null;
  canvas.addEventListener("mousedown", e => { drag = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", () => { drag = null; });
  window.addEventListener("mousemove", e => {
    if (!drag) return;
    view.yaw += 0.01 * (e.clientX - drag[0]);
    view.pitch = Math.max(-1.55, Math.min(1.55, view.pitch + 0.01 * (e.clientY - drag[1])));
    drag = [e.clientX, e.clientY]; draw();
  });
  canvas.addEventListener("wheel", e => { e.preventDefault(); view.zoom *= Math.exp(-0.001 * e.deltaY); draw(); },
                          { passive: false });
  canvas.addEventListener("dblclick", () => { view = Object.assign({}, view0); draw(); });
  window.addEventListener("resize", () => { resize(); fit = null; draw(); });
  slider.value = frame;
  if (hash.get("colour") === "damage" && scales.damage) colour.value = "damage";
  resize(); draw();
  // It plays by itself (issue 37), unless the link chose a frame or the reader asked for less motion.
  const still = window.matchMedia && window.matchMedia("(prefers-reduced-motion: reduce)").matches;
  if (!hash.has("frame") && !still && F > 1) play.click();
})();
