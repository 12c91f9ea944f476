"""Every reported quantity defined once (issue 36, item 2).

A number a run reports in several places (the terminal summary, ``summary.json``,
``refinement.csv``, ``report.html``, the limits and the warnings) is one :class:`Quantity`: its
name, its words, its unit, whether it can be negative and whether it is a headline.  A run's
quantities are read off its summary by :func:`quantities_of`, the only place that knows where in
a summary each one stands; refinement extrapolates exactly these
(:mod:`pydriver.analyses.refinement`), and :func:`headlines` gives each headline quantity the
one value every output shows: the converged (Richardson) value with its error bar where
refinement ran, labelled as such, else the value at the deck's n, labelled with that n.

The names are those refinement.csv has always used (``fd1 [Hz]``, ``fatigue life [h],
shortest``): a stored result reads back unchanged (:mod:`pydriver.stored_results`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass


#: Quantities by their stored names (summary['refinement'], refinement.csv, summary['headline']),
#: and the words a reader is shown for them: the names stay (refinement.csv and readers key on
#: them).
_QUANTITY_WORDS = (
    (re.compile(r"fd(\d+) \[Hz\]"), r"damped frequency of mode \1 [Hz]"),
    (re.compile(r"f(\d+) \[Hz\]"), r"undamped frequency of mode \1 [Hz]"),
    (re.compile(r"peak bending \[Nm\]"), "largest bending moment [Nm]"),
    (re.compile(r"peak torsion \[Nm\]"), "largest torsion moment [Nm]"),
    (re.compile(r"peak axial \[N\]"), "largest axial force [N]"),
    (re.compile(r"peak strain \[-\]"), "largest jacket strain [-]"),
    (re.compile(r"(F[AB]_[xyz]) max \|\.\|"), r"largest |\1| [N]"),
    (re.compile(r"(M[AB]_[xyz]) max \|\.\|"), r"largest |\1| [Nm]"),
    (re.compile(r"DEL strain, worst joint"), "damage-equivalent strain amplitude, worst joint [-]"),
    (re.compile(r"DEL bending, worst joint"), "damage-equivalent bending amplitude, worst joint [Nm]"),
    (re.compile(r"DEL (F[AB]_[xyz])"), r"damage-equivalent amplitude of \1 [N]"),
    (re.compile(r"DEL (M[AB]_[xyz])"), r"damage-equivalent amplitude of \1 [Nm]"),
    (re.compile(r"fatigue life \[h\], shortest"), "shortest fatigue life [h]"),
    (re.compile(r"spectrum life \[h\]"), "life over the usage spectrum, at the worst point [h]"),
    (re.compile(r"decay f_damped \[Hz\]"), "damped frequency of the decay test [Hz]"),
    (re.compile(r"Floquet zeta, least damped \[-\]"), "damping ratio of the least damped Floquet mode [-]"),
    (re.compile(r"Floquet f, least damped \[Hz\]"), "frequency of the least damped Floquet mode [Hz]"),
    (re.compile(r"Floquet \|rho\|, least damped \[-\]"), "|multiplier| of the least damped Floquet mode [-]"),
    (re.compile(r"F_([AB]) ([xyz]) \[N\]"), r"force of support \1 on the cable, \2 [N]"),
    (re.compile(r"M_([AB]) ([xyz]) \[Nm\]"), r"moment of support \1 on the cable, \2 [Nm]"),
    (re.compile(r"tip ([xyz]) \[m\]"), r"free tip, \1 [m]"),
)


def label_of(name: str) -> str:
    """The words shown for a refined quantity's stored name (``'fd1 [Hz]'``: "damped frequency
    of mode 1 [Hz]"); a name without such words is shown as it is."""
    for pattern, words in _QUANTITY_WORDS:
        if pattern.fullmatch(name):
            return pattern.sub(words, name)
    return name


@dataclass(frozen=True)
class Quantity:
    """One reported quantity."""

    name: str                 #: its key in summary['refinement']['quantities'] and refinement.csv
    unit: str                 #: SI unit ('-': dimensionless)
    nonnegative: bool = True  #: cannot be negative (a frequency, a peak, a life): extrapolations are held to it
    headline: bool = False    #: one of the numbers a designer reads first (:func:`headlines`)

    @property
    def label(self) -> str:
        """The quantity in words, for a reader (:func:`label_of`)."""
        return label_of(self.name)


def _frequency(i: int, damped: bool) -> Quantity:
    return Quantity(f"{'fd' if damped else 'f'}{i} [Hz]", "Hz", headline=damped and i == 1)


def quantities_of(summary: dict) -> dict[str, tuple[Quantity, float]]:
    """``{name: (Quantity, value)}`` of every number of a run's summary that refinement
    extrapolates and the outputs report."""
    from pydriver.analyses.registry import reported, sections_of
    out: dict[str, tuple[Quantity, float]] = {}

    def put(q: Quantity, value):
        out[q.name] = (q, float(value))

    spectrum = summary.get("spectrum")
    if spectrum is not None and spectrum.get("life_hours") is not None:
        # A usage spectrum's own number: its life at the worst point (pydriver.analyses.spectrum).
        put(Quantity("spectrum life [h]", "h", headline=True), spectrum["life_hours"])
    if reported(summary).refinement != "scalars":
        return out                  # a diagram over speeds, a spectrum: their own numbers

    for i, f in enumerate(summary.get("frequencies_hz", [])[:6]):
        put(_frequency(i + 1, damped=False), f)
    # Damped frequencies (joint dampers and the Coriolis coupling of a turning frame): the
    # resonance margins are judged on them.  An overdamped mode (0 Hz) is not extrapolated.
    for i, f in enumerate(summary.get("damped_frequencies_hz", [])[:6]):
        if f > 0.0:
            put(_frequency(i + 1, damped=True), f)
    if "equilibrium" in sections_of(summary):        # the reactions of an equilibrium (static, modal)
        for support, wrench in summary.get("reactions", {}).items():
            for kind, unit in (("F", "N"), ("M", "Nm")):
                for comp, value in zip("xyz", wrench[kind]):
                    put(Quantity(f"{kind}_{support} {comp} [{unit}]", unit, nonnegative=False, headline=True), value)
    for comp, value in zip("xyz", summary.get("tip_m", ()) if not summary.get("n_constraints") else ()):
        put(Quantity(f"tip {comp} [m]", "m", nonnegative=False), value)
    peaks = summary.get("peaks", {})
    for qty, unit in (("bending", "Nm"), ("torsion", "Nm"), ("axial", "N"), ("strain", "-")):
        if qty in peaks:
            put(Quantity(f"peak {qty} [{unit}]", unit, headline=qty in ("bending", "strain")), peaks[qty]["max_abs"])
    for name, p in peaks.items():
        if "min" in p:
            unit = "N" if name.startswith("F") else "Nm" if name.startswith("M") else "-"
            put(Quantity(f"{name} max |.|", unit), max(abs(p["min"]), abs(p["max"])))
    fat = summary.get("fatigue")
    if fat:
        top = fat["hotspots"][0]
        put(Quantity(f"DEL {fat['sn_quantity']}, worst joint", fat.get("unit", "-")), top["del_amplitude"])
        if top["life_hours"] is not None:
            # The shortest life over the cable (its worst joint may be another at each n).
            put(Quantity("fatigue life [h], shortest", "h", headline=True), top["life_hours"])
        for c in fat["clamp_loads"]:
            unit = "N" if c["quantity"].startswith("F") else "Nm"
            put(Quantity(f"DEL {c['quantity']}", unit), c["del_amplitude"])
    least = (summary.get("floquet") or {}).get("least_damped")
    if least:
        # The Floquet verdict's mode (pydriver.analyses.floquet_subspace at every level).
        put(Quantity("Floquet zeta, least damped [-]", "-", headline=True), least["damping_ratio"])
        put(Quantity("Floquet f, least damped [Hz]", "Hz"), least["frequency_hz"])
        put(Quantity("Floquet |rho|, least damped [-]", "-"), least["multiplier_abs"])
    decay = summary.get("decay") or {}
    if "f_damped_hz" in decay:
        put(Quantity("decay f_damped [Hz]", "Hz", headline=True), decay["f_damped_hz"])
    return out


def headlines(summary: dict) -> dict:
    """``summary['headline']``: per headline quantity of the run, the ONE value every output
    shows.  With refinement: the Richardson value, its error bar and observed order, the values
    per n, and whether the values are in the asymptotic range; without: the value at the deck's
    n.  Read by the terminal summary, report.html and the limits."""
    refined = (summary.get("refinement") or {}).get("quantities", {})
    ns = (summary.get("refinement") or {}).get("n", [])
    out = {}
    for name, (q, value) in quantities_of(summary).items():
        if not q.headline:
            continue
        entry = {"label": q.label, "unit": q.unit}
        r = refined.get(name)
        if r is not None and "extrapolated" in r:
            entry.update(value=r["extrapolated"], error_estimate=r["error_estimate"],
                         observed_order=r["observed_order"], basis=f"Richardson over n = {', '.join(map(str, ns))}",
                         values_per_n=dict(zip((f"n{n}" for n in ns), r["values"])),
                         asymptotic=bool(r.get("asymptotic", True)))
        else:
            entry.update(value=value, basis=f"n = {summary['n_bodies']}"
                         + (" (its extrapolation is not a result: see the warnings)" if r is not None else ""))
        out[name] = entry
    return out


def unit_of(name: str, summary: dict | None = None) -> str:
    """The unit of a quantity by name (from a summary that has it, else from its name's
    ``[unit]``, else '-')."""
    if summary is not None:
        found = quantities_of(summary).get(name)
        if found is not None:
            return found[0].unit
    if name.endswith("]") and " [" in name:
        return name[name.rindex(" [") + 2:-1]
    return "-"
