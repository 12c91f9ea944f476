"""``DIR/report.html`` of a sweep: one self-contained page (plots embedded) with the base deck,
the grid, how many points finished, the results table and the result-against-parameter plots."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from pydriver.report_html import STYLE, _table, glossary_section
from pydriver.sweep.plots import axis_label

#: Result columns shown (when present) after the id and the swept keys; the rest stay in sweep.csv.
SHOWN = ("f1_hz", "f2_hz", "f1_damped_hz", "zeta1", "FA_x", "FA_y", "FA_z", "FB_x", "FB_y", "FB_z",
         "max_constraint_violation_m", "wall_time_s", "error")


def sweep_report_html(out: Path, manifest: dict, columns: list[str], rows: list[dict], status) -> str:
    """The page; ``columns``/``rows`` as in sweep.csv, ``status`` a SweepStatus."""
    params = manifest["params"]
    shown = ["id"] + params + [c for c in SHOWN if c in columns]
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>sweep {html.escape(out.name)}"
             f"</title><style>{STYLE}</style></head><body>",
             f"<h1>Sweep {html.escape(out.name)}</h1>",
             f"<p>Base deck <code>{html.escape(Path(manifest['base_deck']).name)}</code>; grid "
             + ", ".join(f"<code>--set {html.escape(s)}</code>" for s in manifest["sets"])
             + f"; {status.n_points} points, {status.n_points - len(status.failed) - len(status.missing)} "
               f"finished, {len(status.failed)} failed, {len(status.missing)} not run yet.  SI units, "
               "angles in degrees; every run's own files are in <code>runs/&lt;id&gt;/</code>.</p>"]
    for r in rows:
        if r.get("error"):
            parts.append(f"<p class='warn'>point {html.escape(r['id'])}: {html.escape(str(r['error']))}</p>")
    parts.append("<h2>Results</h2>" + _table(shown, [[r.get(c, "") for c in shown] for r in rows],
                                             left=1 + len(params)))
    images = sorted((out / "plots").glob("*.png")) if (out / "plots").is_dir() else []
    if images:
        parts.append("<h2>Figures</h2>")
        for k, p in enumerate(images, 1):
            data = base64.b64encode(p.read_bytes()).decode()
            text = html.escape(figure_caption(p.name, params))
            parts.append(f"<figure><img alt='{text}' src='data:image/png;base64,{data}'>"
                         f"<figcaption><b>Figure {k}.</b> {text}</figcaption></figure>")
    parts.append(glossary_section("\n".join(parts)))
    parts.append("</body></html>")
    return "\n".join(parts)


def figure_caption(name: str, params: list) -> str:
    """What a sweep plot (``<result>_vs_<parameter>.png``) shows."""
    result, _, param = Path(name).stem.partition("_vs_")
    swept = next((q for q in params if re.sub(r"[^\w.-]", "_", q) == param), param)
    others = [q for q in params if q != swept]
    text = f"{axis_label(result)} of every finished point against {axis_label(swept)}"
    if others:
        text += ", one line per value of " + " and ".join(others)
    return text + " (failed points are left out; the numbers are in sweep.csv)."
