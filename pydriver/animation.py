"""The cable animation of ``report.html``: its data, compact JSON, and the page fragment.

A flight run shows its last revolution (every sample, 360 frames at ``samples_per_rev =
360``), a dynamic run the run or the decay (every sample up to :data:`MAX_FRAMES`, beyond
that evenly decimated; :mod:`pydriver.frames`).  The page draws the cable in 3-D to scale
(one scale on every axis, orthographic) with clamp A, clamp B (or the free tip) and, with a
rotor, the hub (rotor centre) and the rotor axis; each half-body takes the colour of its
nearest joint's jacket strain, or of its damage per flight hour where &fatigue gives one.
Play/pause, a slider (blade azimuth or time), mouse-drag rotation.  The drawing code is
``animation.js`` beside this module, embedded verbatim: the page needs no network.

What is embedded, rounded to what the eye needs (and checked by tests/test_watch.py):

* joint points as integers in units of :data:`UNIT_M` = 0.1 mm (the cable's diameter is
  15 mm, a screen pixel ~1.5 mm at the report's 600 px scene);
* strain and damage to 3 significant digits (the colour map has 256 levels at most);
* the slider's azimuth to 0.1 deg, its time to the sampling step's digits.

Size: n = 44 bodies and 360 frames embed 0.34 MB of data and 12 kB of script; the main job's
whole report is 1.09 MB (README, "Watch it").
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from pydriver.analyses.registry import reported
from pydriver.frames import cable_frames

#: Positions are embedded as integers of this length [m].
UNIT_M = 1.0e-4
#: At most this many frames of a dynamic run (a flight revolution of more samples, too).
MAX_FRAMES = 720


def _g3(values) -> str:
    """A JSON list of numbers to 3 significant digits."""
    return "[" + ",".join(f"{float(v):.3g}" for v in np.ravel(values)) + "]"


def _ints(values) -> str:
    return "[" + ",".join(str(int(v)) for v in np.ravel(values)) + "]"


def animation_data(result, model=None, timeseries_path=None) -> dict | None:
    """The animation's data as Python objects (what :func:`animation_json` embeds), or None
    for a run without a time series.

    Returns
    -------
    dict
        ``n``, ``unit_m``, ``p`` (frames x 3(n+1) integers: P_1 x, y, z, P_2 ...), ``strain``
        (frames x n), ``strain_max``, ``damage`` (n, or None), ``hub`` (integers, or None),
        ``clamp_b``, ``periodic``, ``axis`` (label, unit, digits, values per frame), ``rows``
        (the time-series row of each frame), ``before`` (a design run: its start design's joint
        points, frame for frame like ``p``; else None), ``frame_ms``, ``view`` (yaw, pitch [deg]),
        ``diameter_m``, ``case``.
    """
    frames = cable_frames(result, MAX_FRAMES, timeseries_path)
    if frames is None:
        return None
    s = result.summary
    n = frames.points.shape[1] - 1
    nf = len(frames.rows)
    p = np.rint(frames.points / UNIT_M).astype(np.int64).reshape(nf, -1)
    if frames.azimuth_deg is not None and frames.periodic:
        axis = {"label": "blade azimuth", "unit": "deg", "digits": 1,
                "values": [round(float(a), 1) for a in frames.azimuth_deg]}
    else:
        dt = float(np.median(np.diff(frames.t))) if nf > 1 else 1.0
        digits = min(6, max(0, math.ceil(-math.log10(dt)))) if dt > 0 else 3
        axis = {"label": "t", "unit": "s", "digits": digits,
                "values": [round(float(t), digits) for t in frames.t]}
    rot = s.get("rotor")
    hub = None
    if rot is not None and s.get("frame") == "hub":
        hub = [int(v) for v in np.rint(np.asarray(rot["centre_m"], float) / UNIT_M)]
    diameter = 0.01
    if model is not None:
        from pydriver.analyses.common import joint_geometry
        diameter = float(np.mean(joint_geometry(model)["diameter"]))
    before = _before_points(result, nf, n)
    return {"case": s["case"], "n": n, "unit_m": UNIT_M, "p": p.tolist(), "before": before,
            "strain": frames.strain, "strain_max": float(np.max(frames.strain)) if frames.strain.size else 0.0,
            "damage": frames.damage, "hub": hub, "clamp_b": bool(s.get("n_constraints", 0)),
            "periodic": frames.periodic, "axis": axis, "rows": frames.rows.tolist(),
            "frame_ms": max(16.0, 1000.0 * reported(s).playback_s / max(nf, 1)),
            "view": [-120.0, 30.0], "diameter_m": diameter}


def _before_points(result, frames: int, n: int) -> list | None:
    """A design run's cable at its start design (``result.extra['design_start']``, the deck's own
    parameters), frame for frame with the optimum's, drawn in grey beneath it: the before and
    after of the optimisation in one picture.  None for other runs, or when the two records do
    not match frame for frame (another n, another sampling)."""
    start = result.extra.get("design_start") if hasattr(result, "extra") else None
    if start is None:
        return None
    frames_before = cable_frames(start, MAX_FRAMES)
    if frames_before is None or len(frames_before.rows) != frames or frames_before.points.shape[1] != n + 1:
        return None
    return np.rint(frames_before.points / UNIT_M).astype(np.int64).reshape(frames, -1).tolist()


def animation_json(data: dict) -> str:
    """Compact JSON of :func:`animation_data` (no spaces; strain and damage to 3 significant
    digits; safe inside a <script> element)."""
    parts = []
    for key, value in data.items():
        if key in ("strain",):
            text = "[" + ",".join(_g3(row) for row in value) + "]"
        elif key in ("p", "before"):
            text = "null" if value is None else "[" + ",".join(_ints(row) for row in value) + "]"
        elif key == "damage":
            text = "null" if value is None else _g3(value)
        elif key == "strain_max":
            text = f"{value:.3g}"
        else:
            text = json.dumps(value, separators=(",", ":"))
        parts.append(json.dumps(key) + ":" + text)
    # "<" only occurs in the case name; escaped so that no "</script>" can end the element.
    return ("{" + ",".join(parts) + "}").replace("<", "\\u003c")


def read_embedded(page: str) -> dict | None:
    """The animation data embedded in a report page (for tests and for anyone who wants the
    numbers back), or None."""
    start = page.find('<script type="application/json" id="cable-data">')
    if start < 0:
        return None
    start = page.index(">", start) + 1
    return json.loads(page[start:page.index("</script>", start)])


def animation_html(result, model=None, timeseries_path=None) -> str:
    """The report's section "Watch the cable" (empty for a run without a time series)."""
    data = animation_data(result, model, timeseries_path)
    if data is None:
        return ""
    nf = len(data["p"])
    rows = data["rows"]
    every = "every sample" if len(rows) < 2 or rows[1] - rows[0] == 1 else f"one sample in {rows[1] - rows[0]}"
    what = (f"the last revolution ({nf} frames, {every}; blade azimuth from the downstream direction)"
            if data["periodic"] else f"the run ({nf} frames, {every} of the time series, the last one included)")
    colour = ("jacket strain (drawn), or damage per flight hour (&fatigue; choose below)"
              if data["damage"] is not None else "jacket strain")
    hub = " and the hub (rotor centre, white circle) with the rotor axis (dashed), in the turning hub frame" \
        if data["hub"] else ""
    before = ("  Before and after: the optimum in colour, the deck's start design in grey, azimuth for azimuth."
              if data["before"] is not None else "")
    script = (Path(__file__).with_name("animation.js")).read_text(encoding="utf-8")
    return (f"<h2 id='watch'>Watch the cable</h2><p>The cable over {what}, to scale (one scale on every axis), "
            f"with clamp A (square), clamp B (triangle){hub}; the faint line is clamp B's path.  Each half-body "
            f"takes the colour of its nearest joint's {colour}.{before}  Drag to turn the view.</p>"
            "<div style='border:1px solid #ddd'>"
            "<canvas id='cable-canvas' style='width:100%;height:560px;display:block;cursor:grab'></canvas>"
            "<div style='padding:0.4em 0.6em;display:flex;gap:0.8em;align-items:center;flex-wrap:wrap'>"
            "<button id='cable-play' style='width:5em'>play</button>"
            f"<input id='cable-slider' type='range' min='0' max='{nf - 1}' value='0' style='flex:1;min-width:200px'"
            f" aria-label='{html.escape(data['axis']['label'])}'>"
            "<span id='cable-label' style='min-width:13em'></span>"
            "<label>colour <select id='cable-colour'><option value='strain'>jacket strain</option>"
            "<option value='damage'>damage per flight hour</option></select></label>"
            "<label>speed <select id='cable-speed'><option value='0.25'>0.25x</option><option value='0.5'>0.5x"
            "</option><option value='1' selected>1x</option><option value='2'>2x</option></select></label>"
            "</div></div>"
            f'<script type="application/json" id="cable-data">{animation_json(data)}</script>'
            f"<script>{script}</script>")
