"""``report.html``: one self-contained page per run (plots embedded as PNG data, no outside
files or scripts), to hand to a colleague: the inputs, what was computed, the shape, the loads,
frequencies with their error bars, the Campbell diagram and the fatigue table."""

from __future__ import annotations

import base64
import html
import tempfile
from pathlib import Path

import numpy as np

from pydriver.analyses.registry import sections_of
from pydriver.analyses.resonance import harmonics_text
from pydriver.number_format import with_error
from pydriver.report_text import _num, text_summary
from pydriver.richardson import TWO_GRID_SAFETY
from pydriver.schema import lookup

STYLE = """
body { font-family: sans-serif; max-width: 1180px; margin: 2em auto; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; border-bottom: 2px solid #446; }
h2 { font-size: 1.25em; margin-top: 1.8em; color: #335; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th { background: #eef; } td.l, th.l { text-align: left; }
td.n { white-space: nowrap; font-variant-numeric: tabular-nums; }
td.flag { background: #f8d7da; font-weight: bold; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
figure { margin: 1.2em 0; } figcaption { font-size: 0.92em; color: #333; }
pre { background: #f6f6f6; padding: 0.8em; white-space: pre-wrap; font-size: 0.85em; }
.scroll { overflow-x: auto; max-width: 100%; }
.warn { background: #fff3cd; border-left: 4px solid #e0a800; padding: 0.4em 0.8em; }
dl.glossary dt { font-weight: bold; margin-top: 0.5em; } dl.glossary dd { margin-left: 1.5em; }
"""


def _table(header: list[str], rows: list[list], left=1) -> str:
    """An HTML table; ``left``: the number of leading text columns, or the set of indices of
    the text columns.  Numbers never wrap (a wrapped "8.9937e-" / "04" misreads), and header
    names may break after "_" and "." so that a wide table fits."""
    text_cols = set(range(left)) if isinstance(left, int) else set(left)
    cls = lambda i: ' class="l"' if i in text_cols else ""          # noqa: E731
    out = ["<table><tr>" + "".join(f"<th{cls(i)}>{_breakable(str(h))}</th>" for i, h in enumerate(header))
           + "</tr>"]
    for r in rows:
        out.append("<tr>" + "".join(f"<td{_cell_class(i, v, text_cols)}>{html.escape(_cell(v))}</td>"
                                    for i, v in enumerate(r)) + "</tr>")
    return "<div class='scroll'>" + "".join(out) + "</table></div>"


def _breakable(name: str) -> str:
    """A header name, escaped, with break opportunities after '_' and '.'."""
    return "".join(html.escape(c) + ("<wbr>" if c in "_." else "") for c in name)


def _cell_class(i: int, v, text_cols: set) -> str:
    if i in text_cols:
        return ' class="l"'
    if isinstance(v, str) and v.upper() in ("NOT MET", "WITHIN MARGIN"):
        return ' class="flag"'
    return ' class="n"'


def _cell(v) -> str:
    if isinstance(v, (float, np.floating)):
        return _num(float(v))
    if isinstance(v, np.ndarray):
        # A list of names (&design parameters) is shown as names, numbers in the short number form.
        items = [x if isinstance(x, str) else _num(float(x)) for x in v.ravel()[:12]]
        return ", ".join(items) + (" ..." if v.size > 12 else "")
    return str(v)


def _inputs(model) -> str:
    """Every key the deck sets, with its unit and meaning (from the schema)."""
    rows = []
    for group, key in sorted(model.deck.given):
        k = lookup(group, key)
        rows.append([f"&{group}", key, model.deck[f"{group}.{key}"], k.unit if k else "", k.doc if k else ""])
    return _table(["group", "key", "value", "unit", "meaning"], rows, left=5)


def _images(result) -> list[tuple[str, str]]:
    """The run's plots as (name, base64 PNG)."""
    from pydriver.plots import plot_result
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in plot_result(result, Path(tmp)):
            out.append((name, base64.b64encode((Path(tmp) / name).read_bytes()).decode()))
    return out


def html_report(result, model=None, timeseries_path=None) -> str:
    """The report page of a run (``timeseries_path``: the run's ``timeseries.h5`` or ``.csv``
    when its time series was kept on disk only, for the animation)."""
    s = result.summary
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(s['case'])}</title>"
             f"<style>{STYLE}</style></head><body>",
             f"<h1>{html.escape(s['case'])}: {html.escape(s['analysis'])} analysis</h1>",
             f"<p>Deck <code>{html.escape(s['deck'])}</code>; {s['n_bodies']} bodies, {s['n_coords']} "
             f"coordinates, {s['n_constraints']} constraint rows; equations in the {s['frame']} frame; "
             f"computed in {_job_time(s)} by rotorcable.  SI units, angles in degrees; the abbreviations are "
             "explained in the <a href='#glossary'>glossary</a> at the end.</p>"]
    # The answers first, then the cable moving, then the details (issue 37).
    parts.append(_verdict_section(s))
    from pydriver.animation import animation_html
    parts.append(animation_html(result, model, timeseries_path))
    for w in s.get("warnings", []):
        parts.append(f"<p class='warn'>{html.escape(w)}</p>")
    parts.append("<h2>Summary</h2><pre>" + html.escape(text_summary(s)) + "</pre>")
    if "reactions" in s:
        rows = [[f"F_{k} [N]", *w["F"]] for k, w in s["reactions"].items()]
        rows += [[f"M_{k} [Nm]", *w["M"]] for k, w in s["reactions"].items()]
        loads = s.get("loads_on_supports", {})
        rows += [[f"F on {k} [N]", *w["F"]] for k, w in loads.items()]
        rows += [[f"M on {k} [Nm]", *w["M"]] for k, w in loads.items()]
        parts.append("<h2>Support reactions and loads on the supports</h2><p>F_A ... M_B: the force and moment "
                     "each support exerts on the cable (moment about the clamp point); F on A ... M on B: the load "
                     "the cable puts on the support, what a clamp is sized for (their opposites); "
                     f"{s['frame']} frame.</p>" + _table(["", "x", "y", "z"], rows))
    if "refinement" in s:
        r = s["refinement"]
        rows = [[name, *q["values"], q["extrapolated"], q["error_estimate"],
                 q["observed_order"] if q.get("order_observed", True) else "assumed", q.get("warning") or ""]
                for name, q in r["quantities"].items()]
        if len(r["n"]) >= 3:
            how = ("Richardson extrapolation over the three finest discretisations, with the observed order "
                   f"(expected {r['expected_order']:g}) and the error estimate |extrapolated - finest|.")
        else:
            how = ("Richardson extrapolation over two discretisations, which cannot show the order of "
                   f"convergence: the expected order {r['expected_order']:g} is assumed, and the error estimate "
                   f"is {TWO_GRID_SAFETY:g} |extrapolated - finest| (Roache's safety factor for two grids).  "
                   "Three levels observe the order.")
        parts.append(f"<h2>Converged values (n = {', '.join(map(str, r['n']))})</h2><p>{how}</p>"
                     + _table(["quantity", *[f"n = {n}" for n in r["n"]], "extrapolated", "error +-",
                               "order", "note"], rows, left={0, len(r["n"]) + 4}))
    if result.table is not None:
        t = result.table
        cols = [c for c in ("body", "gamma_deg", "beta_deg", "x_m", "y_m", "z_m", "axial_N", "shear_N",
                            "bending_Nm", "torsion_Nm", "strain") if c in t]
        parts.append("<h2>Shape and loads per body and joint</h2><p>Angles of the thesis (γ, β), centre of "
                     "mass, and the loads joint j carries (tension positive).</p>"
                     + _table(cols, [[t[c][i] for c in cols] for i in range(len(t["body"]))]))
    if "spectrum" in sections_of(s):
        parts.append(_spectrum_section(s["spectrum"]))
    if "design" in s:
        parts.append(_design_section(s["design"]))
    if "modes" in sections_of(s):
        rows = [[i + 1, fu, fd, z] for i, (fu, fd, z) in enumerate(zip(s["frequencies_hz"], s["damped_frequencies_hz"],
                                                                        s["damping_ratios"]))][:12]
        parts.append("<h2>Natural frequencies</h2>" + _table(["mode", "undamped [Hz]", "damped [Hz]", "zeta"], rows))
    if "campbell" in sections_of(s):
        refined = any("rpm_extrapolated" in c for c in s["crossings"])
        rows = [[c["mode"], f"{c['harmonic']}/rev", c["rpm"], c["frequency_hz"]]
                + ([c.get("rpm_extrapolated"), c.get("rpm_error"), c.get("rpm_order")] if refined else [])
                for c in s["crossings"]]
        parts.append("<h2>Campbell diagram: crossings in the operating range</h2>"
                     f"<p>Operating range {s['operating_rpm'][0]:.0f}-{s['operating_rpm'][1]:.0f} rpm; lowest "
                     f"frequency there {_num(s['lowest_frequency_hz'], 4)} Hz against 1/rev up to "
                     f"{_num(s['highest_1rev_hz'], 3)} Hz.</p>"
                     + (_table(["mode", "harmonic", "rpm", "f [Hz]"]
                               + (["rpm converged", "error [rpm]", "order"] if refined else []), rows)
                        if rows else "<p>No crossings.</p>"))
    if s.get("resonance"):
        parts.append(_resonance_section(s["resonance"]))
    if "fatigue" in s:
        f = s["fatigue"]
        rows = [[h["rank"], h["quantity"], h["damage_per_hour"], h["life_hours"] if h["life_hours"] is not None
                 else "no damage", h["del_amplitude"]] for h in f["hotspots"]]
        parts.append("<h2>Fatigue hotspots</h2>"
                     f"<p>{html.escape(f['description'])}</p>"
                     + _table(["rank", "quantity", "damage per flight hour", "life [h]", "DEL amplitude"], rows, left=2))
    images = _images(result)
    if images:
        from pydriver.plots import caption
        parts.append("<h2>Figures</h2>")
        for k, (name, data) in enumerate(images, 1):
            parts.append(f"<figure><img alt='{html.escape(caption(name, s))}' src='data:image/png;base64,{data}'>"
                         f"<figcaption><b>Figure {k}.</b> {html.escape(caption(name, s))}</figcaption></figure>")
    if model is not None:
        parts.append("<h2>Inputs</h2><p>Every value the deck sets (the rest are the defaults of "
                     "docs/deck_reference.md).</p>" + _inputs(model))
    parts.append(glossary_section("\n".join(parts)))
    parts.append("</body></html>")
    return "\n".join(parts)


def _verdict_section(s: dict) -> str:
    """The verdicts (pydriver.verdicts): the questions the run answers, each value as the
    terminal summary prints it, the ones that ask for action marked."""
    from pydriver.verdicts import verdicts
    rows = verdicts(s)
    if not rows:
        return ""
    cells = "".join(f'<tr><td class="l">{html.escape(v.topic)}</td><td class="l">{html.escape(v.value)}</td>'
                    f'<td class="{"flag" if v.flagged else "l"}">{html.escape(v.verdict)}</td></tr>' for v in rows)
    return ("<h2 id='verdicts'>Verdicts</h2><p>The questions this run answers, first; each value as the terminal "
            "summary and summary.json give it (converged, with its error bar, where the run was refined).</p>"
            "<div class='scroll'><table class='verdicts'><tr><th class='l'>question</th>"
            f"<th class='l'>value</th><th class='l'>verdict</th></tr>{cells}</table></div>")


def _job_time(s: dict) -> str:
    """The whole job's computing time, with the refinement levels' share."""
    text = f"{s['wall_time_s']:.2f} s"
    levels = s.get("wall_time_levels_s")
    if levels and "refinement" in s:
        each = ", ".join(f"n = {n}: {w:.2f} s" for n, w in zip(s["refinement"]["n"], levels))
        text += f" (the whole job; refinement levels {each})"
    return text


def _visible_text(page: str) -> str:
    """A page's text without tags, scripts, styles and embedded data."""
    import re
    page = re.sub(r"(?is)<(script|style)\b.*?</\1>", " ", page)
    page = re.sub(r"(?s)<[^>]*>", " ", page)
    return html.unescape(page)


def glossary_section(page: str) -> str:
    """The glossary of every abbreviation and term the page uses (:mod:`pydriver.glossary`)."""
    from pydriver.glossary import used_terms
    terms = used_terms(_visible_text(page))
    items = "".join(f"<dt>{html.escape(t.term)}</dt><dd>{html.escape(t.meaning)}</dd>" for t in terms)
    return f"<h2 id='glossary'>Glossary</h2><dl class='glossary'>{items}</dl>"


def _resonance_section(block: dict) -> str:
    """The resonance margins: every mode against its nearest k/rev harmonic at the operating
    speed(s), the ones within the required margin marked (their shapes are among the figures)."""
    if not block.get("operating_rpm"):
        return f"<h2>Resonance margins</h2><p>{html.escape(block.get('note', ''))}</p>"
    rows = [[r["mode"], r["operating_rpm"], r["frequency_hz"], r["error_hz"] if r.get("error_hz") else "-",
             f"{r['harmonic']}/rev", r["harmonic_hz"], f"{r['worst_margin_percent']:.1f}",
             "WITHIN MARGIN" if r["within_margin"] else "ok"] for r in block["modes"]]
    speeds = ", ".join(f"{x:g}" for x in block["operating_rpm"])
    orders = harmonics_text(block.get("excited_harmonics", block["harmonics"]))
    text = (f"<h2>Resonance margins</h2><p>Each mode's damped frequency (what resonates: damping and the "
            f"Coriolis coupling of a turning frame included) against the nearest rotor harmonic of "
            f"{html.escape(orders)} at {speeds} rpm, in percent of the harmonic, narrowed by the "
            f"frequency's error bar where the run was refined; required: {block['required_margin_percent']:g} % "
            f"(&amp;resonance margin_percent; which harmonics: &amp;resonance excitation).  Modes about "
            f"{html.escape(block['modes_about'])}.</p>")
    if not rows:
        return text + "<p>No mode below the highest harmonic.</p>"
    return text + _table(["mode", "rpm", "f damped [Hz]", "error [Hz]", "nearest", "harmonic [Hz]", "margin [%]",
                          "verdict"], rows)


def _design_section(d: dict) -> str:
    """Before and after of a design optimisation: the objective (and the life), the parameters,
    every start and the frequency margin of every constrained mode at the deck's start and at the
    optimum (the tables above are the optimum's); a design study's refined lives beside."""
    o = d["objective"]
    rows = [[f"objective {o['name']} [{o['unit']}]", o["start"], o["optimum"], "", ""]]
    life = d.get("life_hours")
    if life:
        rows.append([f"{life.get('quantity', 'shortest fatigue life')} [h] (1 / damage per flight hour)",
                     life["start"] if life["start"] is not None else "no damage",
                     life["optimum"] if life["optimum"] is not None else "no damage", "", ""])
    spectrum = d.get("spectrum")
    if spectrum:
        # A spectrum design: its worst point and where its damage comes from, before and after.
        start, opt = spectrum["start"], spectrum["optimum"]
        rows.append(["worst point (joint, deg around)",
                     *(f"{w['worst_point']['joint']}, {w['worst_point']['angle_deg']:.0f}" for w in (start, opt)),
                     "", ""])
        rows += [[f"damage share: {name} [%]", 100.0 * start["damage_shares"].get(name, 0.0),
                  100.0 * share, "", ""] for name, share in opt["damage_shares"].items()]
    rows += [[f"{name} [{p['unit']}]", p["start"], p["optimum"], f"[{_num(p['lower'])}, {_num(p['upper'])}]",
              f"at the {p['at_bound']} bound" if p["at_bound"] else ""] for name, p in d["parameters"].items()]
    if "frequency_margin" in d:
        f = d["frequency_margin"]
        if "f1_undamped_hz" in f["start"]:
            rows.append(["first frequency, undamped [Hz]", f["start"]["f1_undamped_hz"], f["optimum"]["f1_undamped_hz"],
                         "", "not judged"])
        for m in f["constrained_modes"]:
            lo, hi = f["gaps_hz"][str(m)]
            gap = f"kept in [{_num(lo, 4)}, {_num(hi, 4) if hi is not None else 'inf'}] Hz"
            start = f["start"]["damped_hz"].get(str(m), "")
            rows.append([f"mode {m}, damped [Hz]", start, f["optimum"]["damped_hz"][str(m)], gap, ""])
        if f["constrained_modes"]:
            rows.append(["least margin from k/rev [%]", f["start"].get("margin_percent", ""),
                         f["optimum"]["margin_percent"], f">= {f['required_percent']:g}",
                         ("met" if f["satisfied"] else "NOT MET") + f" (mode {f['optimum']['mode']}, "
                         f"{f['optimum']['harmonic']}/rev)"])
    verdict = ("converged" if d["converged"] else "<b>not converged</b>: the optimum is the last design, not a "
               "proven optimum")
    starts = d.get("starts", [])
    text = (f"<h2>Design optimisation: before and after</h2><p>{html.escape(o['doc'])}, minimised by "
            f"{d['method']} with exact gradients from {len(starts) or 1} start(s) ({d['runs']} runs in all); the "
            f"best, start '{html.escape(d.get('best_start', 'deck'))}', in {d['iterations']} iterations: {verdict} "
            f"({html.escape(d['message'])}).  The optimum is {html.escape(d.get('optimum_is', 'a local optimum'))}"
            + (f"; at a bound: {html.escape(', '.join(d['at_bound']))}" if d.get("at_bound") else "")
            + ".  The results above are those of the optimum (<code>optimum.nml</code>).</p>")
    if "frequency_margin" in d:
        f = d["frequency_margin"]
        shifted = (" shifted by its discretisation error f(converged) - f(n) (&amp;design frequency_levels = "
                   f"{f['frequency_levels']})" if "discretisation_shift_hz" in f else "")
        above = ", ".join(f"mode {m} {_num(v, 4)} Hz" for m, v in f.get("not_excited", {}).items())
        text += (f"<p>Frequency margin: every mode's damped frequency{shifted} at least "
                 f"{f['required_percent']:g} % from {html.escape(harmonics_text(f['harmonics']))} at "
                 f"{', '.join(f'{r:g}' for r in f['operating_rpm'])} rpm, each kept in the gap between harmonics "
                 f"where it starts; modes above {_num(f['highest_excited_hz'], 4)} Hz (one harmonic above the "
                 "highest) are not excited, the lowest of them kept above the highest harmonic's band"
                 + (f" (not constrained: {html.escape(above)})" if above else "") + ".</p>")
    text += _table(["", "start", "optimum", "bounds", "note"], rows, left={0, 3, 4})
    if starts:
        srows = []
        for r in starts:
            if "error" in r:
                srows.append([r["label"], "", "", "could not be run", html.escape(r["error"])])
                continue
            fm = r.get("frequency_margin", {}).get("optimum", {})
            srows.append([r["label"], r["objective"]["start"], r["objective"]["optimum"],
                          "converged" if r["converged"] else "not converged",
                          (f"margin {fm['margin_percent']:.2f} % (mode {fm['mode']}); " if "margin_percent" in fm
                           else "") + (", ".join(f"{k} at the {b} bound" for k, b in r["at_bound"].items())
                                       or "no parameter at a bound")])
        text += ("<p>Every start (each a local optimisation; &amp;design starts):</p>"
                 + _table(["start", f"objective at the start [{o['unit']}]", f"at its optimum [{o['unit']}]",
                           "verdict", "note"], srows, left={0, 3, 4}))
    refined = d.get("refined")
    if refined:
        rrows = []
        for key in ("before", "after"):
            r = refined[key]
            rrows.append([key, r["extrapolated_h"], r["error_estimate_h"], r["values_h"][0], r["fd1_hz"],
                          r["fd1_error_hz"], "" if r["margin_percent"] is None else
                          f"{r['margin_percent']:.2f} % (mode {r['margin_mode']}, {r['nearest_harmonic']}/rev; "
                          f"{r['worst_margin_percent']:.2f} % at the edge of its error bar)"])
        text += (f"<p>Refined (n = {', '.join(map(str, refined['before']['n']))}, Richardson; rotorcable study "
                 f"design): the life grows by x {_num(refined['life_gain'], 3)}.</p>"
                 + _table(["design", "life [h]", "error [h]", f"life at n = {refined['before']['n'][0]} [h]",
                           "mode 1 damped [Hz]", "error [Hz]", "closest margin"], rrows, left={0, 6}))
    return text


def _spectrum_section(sp: dict) -> str:
    """A usage spectrum: the life with its error bar and the safe life, the damage by regime and
    from the ground-air-ground cycles at the worst point, the hotspots and the blade fits."""
    out = [f"<h2>Usage spectrum: life and damage by regime</h2><p>{html.escape(sp['description'])}.</p>"]
    if sp["life_hours"] is None:
        return out[0] + "<p>No point of the cable takes damage: the life is unbounded.</p>"
    life = f"<b>{_num(sp['life_hours'], 4)} h</b> at n = {sp['n_bodies']}"
    if "life_extrapolated_hours" in sp:
        life += (f"; converged <b>{with_error(sp['life_extrapolated_hours'], sp['life_error_hours'])} h</b>"
                 f" (Richardson over n = "
                 f"{', '.join(str(lv['n']) for lv in sp['levels'])})")
    out.append(f"<p>Life over the spectrum: {life}.  Safe life (life / scatter factor {sp['scatter_factor']:g}): "
               f"<b>{_num(sp['safe_life_hours'], 4)} h</b>.  Worst point: {html.escape(sp['worst_point']['where'])}, "
               f"damage {_num(sp['damage_per_flight_hour'], 4)} per flight hour.</p>")
    rows = []
    for r in sp["regimes"]:
        alone = r["life_alone_hours"] if r["life_alone_hours"] is not None else "no damage"
        conv = (with_error(r['life_alone_extrapolated_hours'], r['life_alone_error_hours'])
                if "life_alone_extrapolated_hours" in r else "")
        rows.append([r["name"], r["time_share"], r["damage_per_hour_in_regime"], r["damage_per_flight_hour"],
                     f"{100.0 * r['damage_share']:.3g} %", alone, conv])
    for name in ("ground-air-ground", "start-stops"):
        if sp["flights_per_hour"] > 0.0:
            share = sp["damage_shares"][name]
            rows.append([name, "-", "-", share * sp["damage_per_flight_hour"], f"{100.0 * share:.3g} %", "-", ""])
    out.append("<p>At the worst point: each regime's damage per hour in that regime and per flight hour (times its "
               "share of the flight time), its share of the total damage, and its life if it were flown alone (at "
               "the finest n; converged where the regime's own levels give it).</p>"
               + _table(["regime", "time share", "damage per hour in regime", "damage per flight hour",
                         "share of damage", "life alone [h]", "life alone converged [h]"], rows))
    if "gag_cycle" in sp:
        g = sp["gag_cycle"]
        out.append(f"<p>Ground-air-ground cycle at the worst point ({sp['flights_per_hour']:g} per flight hour): from "
                   f"{_num(g['low'], 4)} to {_num(g['high'], 4)} ({html.escape(sp['sn_quantity'])}; rest state "
                   f"{_num(g['rest'], 4)}), damage {_num(g['damage_per_cycle'], 3)} per cycle.</p>")
    hot = [[h["rank"], h["quantity"], h["damage_per_hour"], h["life_hours"] if h["life_hours"] is not None
            else "no damage"] for h in sp["hotspots"]]
    out.append("<h3>Hotspots over the spectrum</h3>"
               + _table(["rank", "where", "damage per flight hour", "life [h]"], hot, left=2))
    fits = [[r["name"], r["blade_file"], angle, f["residual_rms_deg"], f["residual_max_deg"],
             f["residual_max_at_azimuth_deg"]] for r in sp["regimes"] for angle, f in r.get("blade_fit", {}).items()]
    if fits:
        out.append("<h3>Blade motion from data</h3><p>The blade tables fitted as Fourier series in the azimuth "
                   "(least squares): the residual at the table's azimuths.</p>"
                   + _table(["regime", "file", "angle", "rms [deg]", "largest [deg]", "at azimuth [deg]"], fits,
                            left=3))
    return "".join(out)
