"""The short summary a person reads in the terminal after a run (``--json`` keeps the machine
form): what ran, the reactions with units, frequencies, peaks, warnings, where the files went."""

from __future__ import annotations

import re

from pydriver.analyses.registry import sections_of
from pydriver.analyses.resonance import harmonics_text
from pydriver.number_format import num as _num, with_error
from pydriver.quantities import label_of as quantity_label
from pydriver.verdicts import verdict_lines


def _row(label: str, values, width: int = 12) -> str:
    return f"    {label:<22}" + "".join(f"{_num(v):>{width}}" for v in values)


def text_summary(summary: dict, files: dict | None = None) -> str:
    """The terminal summary of a run's ``summary.json``."""
    s = summary
    lines = [f"{s['case']}  ({s['analysis']}, {s['n_bodies']} bodies, {s['n_coords']} coordinates, "
             f"{s['n_constraints']} constraint rows, {s['frame']} frame)  {s['wall_time_s']:.2f} s"]
    # The answers first (issue 37), each value as every output prints it (pydriver.verdicts).
    lines += verdict_lines(s)
    solver = s.get("solver", {})
    if "steps" in solver:
        lines.append(f"  integration: {solver['steps']} steps, {solver['residual_evals']} residuals")
    elif "newton_iterations" in solver:
        lines.append(f"  equilibrium: {solver['newton_iterations']} Newton iterations")
    if "revolutions" in s:
        lines.append(f"  periodic after {s['revolutions']} revolutions (last difference "
                     f"{s['periodic_difference_m'][-1]:.1e} m < {s['periodic_tol_m']:g} m)")
    if "reactions" in s:
        where = "hub" if s["frame"] == "hub" else "inertial"
        lines.append(f"  reactions (support on chain, {where} frame" + (", at the end)" if "t_end_s" in s or
                                                                                     "revolutions" in s else ")"))
        lines.append(f"    {'':<22}" + "".join(f"{c:>12}" for c in "xyz"))
        for side, w in s["reactions"].items():
            lines.append(_row(f"F_{side} [N]", w["F"]))
            lines.append(_row(f"M_{side} [Nm]", w["M"]))
    if "tip_m" in s:
        lines.append(_row("tip [m]", s["tip_m"]))
    if s.get("loads_on_supports"):
        # What a clamp is sized for: the load the cable puts on it, the reaction's opposite.
        lines.append("  loads on the supports (cable on support, what a clamp carries):")
        for side, w in s["loads_on_supports"].items():
            lines.append(_row(f"F on {side} [N]", w["F"]))
            lines.append(_row(f"M on {side} [Nm]", w["M"]))
    if s.get("max_constraint_violation_m"):
        lines.append(f"  clamp closed to {s['max_constraint_violation_m']:.1e} m")
    if "frequencies_hz" in s and "modes" in sections_of(s):
        fu = ", ".join(_num(f, 4) for f in s["frequencies_hz"][:6])
        fd = ", ".join(_num(f, 4) for f in s["damped_frequencies_hz"][:6])
        lines.append(f"  natural frequencies, undamped [Hz]: {fu}")
        lines.append(f"  damped [Hz]:                        {fd}")
    if "design" in s:
        lines += design_lines(s["design"])
    if "decay" in s and "f_damped_hz" in s["decay"]:
        d = s["decay"]
        lines.append(f"  decay test: {_num(d['f_damped_hz'], 5)} Hz damped"
                     + (f", zeta = {_num(d['zeta'], 3)}" if "zeta" in d else ""))
    if "campbell" in sections_of(s):
        lines.append(f"  lowest (damped) frequency in the operating range {_num(s['lowest_frequency_hz'], 4)} Hz; "
                     f"1/rev reaches {_num(s['highest_1rev_hz'], 3)} Hz")
        lines.append(f"  crossings with {harmonics_text(s.get('excited_harmonics', s['harmonics']))} in the operating "
                     f"range: {len(s['crossings'])}")
        for c in s["crossings"][:8]:
            converged = (f", converged {with_error(c['rpm_extrapolated'], c['rpm_error'])} rpm"
                         if c.get("rpm_extrapolated") is not None else "")
            lines.append(f"    mode {c['mode']} x {c['harmonic']}/rev at {c['rpm']:.0f} rpm "
                         f"({_num(c['frequency_hz'], 4)} Hz){converged}")
    if "peaks" in s:
        p = s["peaks"]
        # With refinement the converged values lead the verdicts; these are the finest level's and say so.
        level = f" (at n = {s['n_bodies']})" if "refinement" in s else ""
        lines.append(f"  largest bending moment {_num(p['bending']['max_abs'])} Nm at joint "
                     f"{p['bending']['joint']}, azimuth {p['bending']['azimuth_deg']:.0f} deg; largest jacket "
                     f"strain {_num(p['strain']['max_abs'], 3)}{level}")
    if "fatigue" in s:
        top = s["fatigue"]["hotspots"][:3]
        at_n = f" at n = {s['n_bodies']}" if "refinement" in s else ""
        for h in top:
            life = h["life_hours"]
            life_text = "no damage" if life is None else f"{_num(life, 3)} h"
            lines.append(f"  fatigue hotspot {h['rank']}: {h['quantity']}, life {life_text}{at_n}")
    lines += spectrum_lines(s.get("spectrum"))
    if "refinement" in s:
        q = {k: r for k, r in s["refinement"]["quantities"].items() if "extrapolated" in r}
        # Frequencies, peak loads and the worst joint's DEL first; the clamp-load maxima and
        # DELs are in refinement.csv and report.html.
        first = [k for k in q if k.startswith(("fd", "peak", "DEL strain", "DEL bending", "fatigue life", "F_", "M_",
                                               "tip", "decay"))]
        shown = (first or list(q))[:10]
        lines.append("  converged values (Richardson over n = "
                     + ", ".join(str(n) for n in s["refinement"]["n"]) + "):"
                     + ("" if q else " none that is a result (the warnings say why)"))
        for name in shown:
            r = q[name]
            order = (f"order {r['observed_order']:.2f}" if r.get("order_observed", True)
                     else f"order {r['observed_order']:g} assumed")
            lines.append(f"    {quantity_label(name):<40}{with_error(r['extrapolated'], r['error_estimate'])} "
                         f"({order})")
        if len(q) > len(shown):
            lines.append(f"    ... {len(q) - len(shown)} more (clamp loads, damage-equivalent loads) in refinement.csv")
    lines += _resonance_lines(s.get("resonance"))
    if "shooting" in s:
        sh = s["shooting"]
        lines.append(f"  periodic state by shooting: {sh['newton_iterations']} Newton iterations "
                     f"({sh['revolutions_integrated']} revolutions integrated in all)")
    for w in s.get("warnings", []):
        lines.append(f"  warning: {w}")
    if files:
        folder = {str(p.parent) for p in files.values()}
        names = ", ".join(_collapse_series(sorted(p.name for p in files.values())))
        lines.append(f"  files: {' '.join(sorted(folder))}/ ({names})")
    return "\n".join(lines)


def _spectrum_design_lines(sp: dict | None) -> list[str]:
    """A spectrum design's worst point and where its damage comes from, before and after."""
    if not sp:
        return []
    lines = []
    for when in ("start", "optimum"):
        w = sp[when]
        shares = ", ".join(f"{name} {100.0 * v:.1f} %" for name, v in w["damage_shares"].items())
        lines.append(f"    {when}: worst point joint {w['worst_point']['joint']}, "
                     f"{w['worst_point']['angle_deg']:.0f} deg around; damage from {shares}")
    return lines


def design_lines(d: dict) -> list[str]:
    """A design run: objective (and life) before and after, its starts, the parameters (which sit
    on a bound), the frequency margin of every constrained mode."""
    o = d["objective"]
    starts = d.get("starts", [])
    lines = [f"  design: {o['name']} {_num(o['start'])} -> {_num(o['optimum'])} {o['unit']} "
             f"({d['method']}, best start '{d.get('best_start', 'deck')}' of {max(len(starts), 1)}, "
             f"{d['iterations']} iterations, {d['runs']} runs in all, "
             f"{'converged' if d['converged'] else 'NOT converged'}: {d['message']})"]
    life = d.get("life_hours")
    if life:
        text = [("no damage" if v is None else f"{_num(v, 4)} h") for v in (life["start"], life["optimum"])]
        lines.append(f"    {life.get('quantity', 'shortest fatigue life')} {text[0]} -> {text[1]} "
                     "(1 / damage per flight hour)")
    lines += _spectrum_design_lines(d.get("spectrum"))
    for name, p in d["parameters"].items():
        bound = f" (at the {p['at_bound']} bound)" if p["at_bound"] else ""
        lines.append(f"    {name} [{p['unit']}]: {_num(p['start'])} -> {_num(p['optimum'])}{bound}")
    if "optimum_is" in d:
        lines.append(f"    the optimum is {d['optimum_is']}")
    for r in starts:
        if "error" in r:
            lines.append(f"    start '{r['label']}': could not be run")
            continue
        fm = r.get("frequency_margin", {}).get("optimum", {})
        margin = (f", margin {fm['margin_percent']:.1f} % (mode {fm['mode']})" if "margin_percent" in fm else "")
        lines.append(f"    start '{r['label']}': {_num(r['objective']['start'])} -> {_num(r['objective']['optimum'])} "
                     f"{o['unit']}, {'converged' if r['converged'] else 'not converged'}{margin}")
    if "frequency_margin" in d:
        f = d["frequency_margin"]
        lines.append(f"    frequency margin of the damped frequencies (required {f['required_percent']:g} % from "
                     f"{harmonics_text(f['harmonics'])} at {', '.join(f'{r:g}' for r in f['operating_rpm'])} rpm): "
                     + ("no mode below " + f"{_num(f['highest_excited_hz'], 4)} Hz" if not f["constrained_modes"] else
                        f"least {f['start']['margin_percent']:.1f} % (mode {f['start']['mode']}) -> "
                        f"{f['optimum']['margin_percent']:.1f} % (mode {f['optimum']['mode']}, nearest "
                        f"{f['optimum']['harmonic']}/rev)"))
        for key in ("start", "optimum"):
            damped = ", ".join(f"mode {m} {_num(v, 4)}" for m, v in f[key]["damped_hz"].items())
            undamped = (f"; first undamped {_num(f[key]['f1_undamped_hz'], 4)} Hz" if "f1_undamped_hz" in f[key]
                        else "")
            shifted = " (converged: shifted by f(converged) - f(n))" if "discretisation_shift_hz" in f else ""
            lines.append(f"      {key}: damped [Hz]{shifted} {damped or '-'}{undamped}")
        if f.get("not_excited"):
            above = ", ".join(f"mode {m} {_num(v, 4)} Hz" for m, v in f["not_excited"].items())
            lines.append(f"      not constrained (above {_num(f['highest_excited_hz'], 4)} Hz, one harmonic above the "
                         f"highest): {above}")
    return lines


def _collapse_series(names: list[str]) -> list[str]:
    """File names with numbered series shown as their first and last (``cable_0000.vtu ...
    cable_0359.vtu (360 files)``): a ParaView export writes hundreds."""
    out, series = [], {}
    for name in names:
        m = re.fullmatch(r"(.*_)(\d{4})(\.\w+)", name)
        if m:
            series.setdefault((m.group(1), m.group(3)), []).append(name)
        else:
            out.append(name)
    for group in series.values():
        out.append(group[0] if len(group) == 1 else f"{group[0]} ... {group[-1]} ({len(group)} files)")
    return sorted(out)


def _percent(x: float) -> str:
    return f"{100.0 * x:.3g} %" if x >= 1e-5 else "< 0.001 %"


def spectrum_lines(sp: dict | None) -> list[str]:
    """A usage spectrum's life, safe life, worst point and damage by regime."""
    if not sp:
        return []
    lines = [f"  usage spectrum: {len(sp['regimes'])} regimes, {sp['flights_per_hour']:g} flights (ground-air-ground "
             f"cycles) and {sp['flights_per_hour'] * sp['start_stops_per_flight']:g} rotor start-stops per flight hour; "
             f"mean stress: {sp['mean_stress']}"]
    if sp["life_hours"] is None:
        lines.append("  no point of the cable takes damage over the spectrum: the life is unbounded")
        return lines
    life = f"  life over the spectrum {_num(sp['life_hours'], 4)} h at n = {sp['n_bodies']}"
    if "life_extrapolated_hours" in sp:
        order = (f"order {sp['observed_order']:.2f}" if sp["order_observed"]
                 else f"order {sp['observed_order']:g} assumed")
        life += f"; converged {with_error(sp['life_extrapolated_hours'], sp['life_error_hours'])} h ({order})"
    lines.append(life)
    lines.append(f"  safe life {_num(sp['safe_life_hours'], 4)} h (life / scatter factor {sp['scatter_factor']:g})")
    lines.append(f"  worst point: {sp['worst_point']['where']}; damage there per flight hour "
                 f"{_num(sp['damage_per_flight_hour'], 4)}")
    shares = ", ".join(f"{name} {_percent(x)}" for name, x in sp["damage_shares"].items())
    lines.append(f"  damage there by regime: {shares}")
    for r in sp["regimes"]:
        for angle, fit in r.get("blade_fit", {}).items():
            lines.append(f"  regime '{r['name']}': {angle} angle of {r['blade_file']} fitted, residual rms "
                         f"{_num(fit['residual_rms_deg'], 2)} deg, largest {_num(fit['residual_max_deg'], 2)} deg")
    return lines


def _resonance_lines(block: dict | None) -> list[str]:
    """The resonance margins (modal, Campbell and flight runs): one line per mode and speed."""
    if not block:
        return []
    if not block.get("operating_rpm"):
        return [f"  resonance margins: {block.get('note', 'no operating speed')}"]
    speeds = ", ".join(f"{r:g}" for r in block["operating_rpm"])
    orders = block.get("excited_harmonics", block["harmonics"])
    lines = [f"  resonance margins of the damped frequencies at {speeds} rpm (required "
             f"{block['required_margin_percent']:g} % from {harmonics_text(orders)}; modes about "
             f"{block['modes_about']}):"]
    if not block["modes"]:
        lines.append("    no mode below the highest harmonic")
    for r in block["modes"][:8]:
        err = f" +- {_num(r['error_hz'], 2)}" if r.get("error_hz") else ""
        flag = "   <- within the margin" if r["within_margin"] else ""
        lines.append(f"    mode {r['mode']:<3}{_num(r['frequency_hz'], 4):>9}{err} Hz   nearest "
                     f"{r['harmonic']}/rev = {_num(r['harmonic_hz'], 4)} Hz at {r['operating_rpm']:g} rpm   "
                     f"margin {r['worst_margin_percent']:.1f} %{flag}")
    if len(block["modes"]) > 8:
        lines.append(f"    ... {len(block['modes']) - 8} more in resonance.csv")
    return lines
