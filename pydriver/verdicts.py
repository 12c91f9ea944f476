"""The verdicts a designer reads first (issue 37): one row per question the run answers — how
long the cable lives, how far its modes sit from the rotor harmonics, whether its periodic
motion is stable, whether the deck's limits are met, whether its equilibrium is stable, how
large its own integration error is.  The terminal summary and ``report.html`` open with these
rows, and both print each value by :func:`value_text` from the same entry of the summary
(``summary['headline']``, ``['resonance']``, ``['limits']`` ...): one number, one definition
(issue 36).
"""

from __future__ import annotations

from dataclasses import dataclass

from pydriver.number_format import num as _num, with_error
from pydriver.number_format import value_with_unit as limit_value_text


@dataclass(frozen=True)
class Verdict:
    """One answer: the question, the value in words and units, and the verdict."""

    topic: str
    value: str
    verdict: str           #: 'ok', 'NOT MET', 'WITHIN MARGIN', 'stable', 'UNSTABLE', 'not judged', ...
    flagged: bool = False  #: the verdict asks for action


def limit_verdict(row: dict) -> str:
    """'NOT MET', 'ok' or 'not judged' (no limit in the deck) of a summary['limits'] row."""
    if row["limit"] is None:
        return "not judged"
    return "NOT MET" if row["exceeded"] else "ok"


def value_text(value: float, unit: str, error: float | None = None, basis: str = "", asymptotic: bool = True) -> str:
    """A headline number as every output prints it: value +- error unit (basis; a note when the
    values are not yet in the asymptotic range)."""
    text = limit_value_text(value, unit) if error is None else (
        f"{with_error(value, error)} {'' if unit == '-' else unit}".rstrip())
    notes = [basis] if basis else []
    if not asymptotic:
        notes.append("not yet in the asymptotic range")
    return text + (f" ({'; '.join(notes)})" if notes else "")


def headline_text(entry: dict) -> str:
    """:func:`value_text` of a ``summary['headline']`` entry."""
    return value_text(entry["value"], entry["unit"], entry.get("error_estimate"), entry.get("basis", ""),
                      entry.get("asymptotic", True))


def _limits(s: dict) -> list[Verdict]:
    out = []
    # The life first: it is the question a designer asks first.
    for r in sorted(s.get("limits") or [], key=lambda r: r["unit"] != "h"):
        error = r.get("error_estimate") or None
        value = value_text(r["value"], r["unit"], error, r.get("basis", ""), r.get("asymptotic", True))
        against = "" if r["limit"] is None else f"; limit {r['sense']} {limit_value_text(r['limit'], r['unit'])}"
        verdict = limit_verdict(r)
        out.append(Verdict(r["quantity"], f"{value}, {r['where']}{against}",
                           verdict + ("" if r["limit"] is not None else f" (no {r['key']})"),
                           flagged=verdict == "NOT MET"))
    return out


def _resonance(s: dict) -> list[Verdict]:
    block = s.get("resonance")
    if not block or not block.get("operating_rpm"):
        return []
    c = block.get("closest")
    if c is None:
        return [Verdict("resonance margins", "no mode below the highest harmonic", "ok")]
    err = c.get("error_hz")
    freq = value_text(c["frequency_hz"], "Hz", err if err else None)
    value = (f"closest: mode {c['mode']} at {freq}, {c['worst_margin_percent']:.1f} % from {c['worst_harmonic']}/rev "
             f"at {c['operating_rpm']:g} rpm (required {block['required_margin_percent']:g} %)")
    flagged = bool(block.get("flagged"))
    verdict = f"WITHIN MARGIN ({len(block['flagged'])} mode{'s' if len(block['flagged']) > 1 else ''})" if flagged \
        else "ok"
    return [Verdict("resonance margins", value, verdict, flagged)]


def _floquet(s: dict) -> list[Verdict]:
    fl = s.get("floquet")
    if not fl or not fl.get("n_modes"):
        return []
    where = f", n = {fl['n_bodies']}" if "n_bodies" in fl else ""
    ld = fl["least_damped"]
    refined = (s.get("headline") or {}).get("Floquet zeta, least damped [-]")
    if refined is not None and "error_estimate" in refined:
        # Refined (floquet_subspace.py at every level): the converged ratio with its error bar.
        value = (f"largest |multiplier| {fl['max_multiplier_abs']:.4g}{where}; least damped mode "
                 f"{_num(ld['frequency_hz'], 4)} Hz, damping ratio {headline_text(refined)}")
    else:
        value = (f"largest |multiplier| {fl['max_multiplier_abs']:.4g}; least damped mode "
                 f"{_num(ld['frequency_hz'], 4)} Hz, damping ratio {ld['damping_ratio']:.3g}{where}")
    return [Verdict("stability of the periodic motion (Floquet)", value, "stable" if fl["stable"] else "UNSTABLE",
                    not fl["stable"])]


def _equilibrium(s: dict) -> list[Verdict]:
    st = s.get("equilibrium_stability")
    if not st:
        return []
    value = (f"smallest stiffness eigenvalue {_num(st['smallest_stiffness_eigenvalue_Nm_per_rad'], 4)} Nm/rad; "
             f"{st['zero_stiffness_modes']} mode(s) without stiffness")
    return [Verdict("equilibrium", value, st["verdict"], st["verdict"] != "stable")]


def _integration(s: dict) -> list[Verdict]:
    from pydriver.analyses.integration_error import WARN_SHARE
    ie = s.get("integration_error")
    if not ie:
        return []
    if "relative_change" not in ie:
        return [Verdict("integration error", ie.get("why", ""), "not estimated")]
    family, worst = max(ie["relative_change"].items(), key=lambda kv: kv[1], default=("loads", 0.0))
    value = f"{worst:.2g} of the largest value ({family}; the run again at rtol {ie['check_rtol']:g})"
    loose = worst > WARN_SHARE
    return [Verdict("integration error", value, "tighten rtol" if loose else "ok", loose)]


def _headlines(s: dict, skip: set) -> list[Verdict]:
    out = []
    for name, entry in (s.get("headline") or {}).items():
        if name in skip:
            continue
        out.append(Verdict(_words(entry["label"]), headline_text(entry), "-"))
    return out


def _words(label: str) -> str:
    """A quantity's words without their "[unit]" (the value carries it)."""
    return label[:label.rindex(" [")] if label.endswith("]") and " [" in label else label


def verdicts(summary: dict) -> list[Verdict]:
    """The verdict rows of a run, in the order a designer reads them."""
    s = summary
    judged = {"fatigue life [h], shortest", "peak strain [-]", "spectrum life [h]"} if s.get("limits") else set()
    rows = []
    life = (s.get("headline") or {}).get("fatigue life [h], shortest")
    if life is not None and not s.get("limits"):
        rows.append(Verdict("shortest fatigue life", headline_text(life), "not judged"))
    rows += _limits(s) + _resonance(s) + _floquet(s) + _equilibrium(s) + _integration(s)
    # The reactions follow in a table of their own.
    reactions = {name for name in (s.get("headline") or {}) if name.startswith(("F_", "M_"))}
    # The Floquet damping ratio is in the Floquet row.
    rows += _headlines(s, judged | reactions | {"fatigue life [h], shortest", "Floquet zeta, least damped [-]"})
    return rows


def verdict_lines(summary: dict) -> list[str]:
    """The verdicts as lines of the terminal summary."""
    rows = verdicts(summary)
    if not rows:
        return []
    width = min(max(len(r.topic) for r in rows), 44)
    return ["  verdicts:"] + [f"    {r.topic:<{width}}  {r.value}" + ("" if r.verdict == "-" else f"  [{r.verdict}]")
                              for r in rows]
