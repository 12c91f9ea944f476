"""The design optimiser's frequency margin (``&design frequency_margin_percent``; docs/model.md,
"Design optimisation"): the constraint that keeps every excited mode away from the rotor
harmonics, judged as the resonance check judges it.

* **Which frequency.**  The damped frequencies of the linearised motion (the modal analysis's
  pairing of each undamped mode with its damped root,
  :func:`pydriver.analyses.linear_modes.damped_partners`), as the resonance table and the
  Campbell diagram: the damped motion is what resonates (docs/model.md, "Resonance margins").
  Their exact derivatives are ``fd{k}_hz`` of :func:`pydriver.analyses.sensitivities.modal_sensitivities`.
* **Which harmonics.**  Those of the resonance check, :func:`pydriver.analyses.resonance.excited_harmonics`
  (``&resonance harmonics, excitation, blades``) at the operating speed(s), and the margin is
  :func:`pydriver.analyses.resonance.harmonic_margin`'s.
* **Which modes.**  Every mode whose damped frequency at the start lies at or below one harmonic
  above the highest considered, (K + 1) Omega, the modes the resonance table lists
  (:func:`pydriver.analyses.resonance.highest_excited_hz`), and the lowest mode above them; each
  keeps the gap between forbidden bands it starts in (:func:`pydriver.design_measures.allowed_gap`):
  one constraint pair per mode.  The lowest mode above is kept above the highest band, so that no
  mode enters the harmonics from above (the modes above it are higher still).
* **Which n.**  With ``&design frequency_levels`` > 1 each mode's frequency is shifted by its
  discretisation error f(converged) - f(n), Richardson over n, 2n (, 4n) of the modal analysis
  of the same design (:func:`discretisation_shift`), so that the converged cable keeps the
  margin, not the n-body model; and the gap's edges move in by the converged frequency's error
  bar, so that the margin holds at the worst end of the error bar, where the resonance verdict
  judges it (:mod:`pydriver.analyses.resonance`).
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.resonance import excited_harmonics, harmonic_margin, highest_excited_hz, operating_speeds
from pydriver.design_measures import allowed_gap, forbidden_bands
from pydriver.errors import RunError
from pydriver.richardson import richardson, richardson_two


def error_bars(shifts: dict) -> dict:
    """{mode: error bar [Hz]} of the converged frequencies of :func:`discretisation_shift`'s
    ``{mode: (shift, error)}``."""
    return {mode: float(err) for mode, (_, err) in shifts.items()}


def _narrowed(lo: float, hi: float, error: float) -> tuple[float, float]:
    """A gap with each finite edge moved in by ``error`` (at most a quarter of the gap: a
    frequency whose error bar is wider than its gap cannot be placed by it; the edges stay)."""
    error = min(error, 0.25 * (hi - lo)) if np.isfinite(hi) else error
    return (lo + error if lo > 0.0 else lo), (hi - error if np.isfinite(hi) else hi)


def damped_name(mode: int) -> str:
    """The evaluation's name of mode ``mode``'s damped frequency (as in sensitivities.csv)."""
    return f"fd{mode}_hz"


class FrequencyMargin:
    """The margin of one design deck: operating speeds, excited harmonics, forbidden bands.

    Parameters
    ----------
    start_model : Model
        The deck's model at the start (its operating speeds and &resonance keys).
    required_percent : float
        ``&design frequency_margin_percent``.
    """

    def __init__(self, start_model, required_percent: float):
        deck = start_model.deck
        self.required_percent = float(required_percent)
        self.speeds = [r for r in operating_speeds(start_model) if r > 0.0]
        if not self.speeds:
            deck.fail("design", "frequency_margin_percent",
                      "needs an operating rotor speed: the deck's rotor does not turn; set &resonance "
                      "operating_rpm (or &loads rotor_rpm / &rotor rpm)")
        self.excitation = deck["resonance.excitation"]
        self.harmonics = excited_harmonics(deck)
        self.bands = forbidden_bands(self.speeds, self.harmonics, self.required_percent)
        #: modes above this at the start are not excited (as the resonance table does not list them)
        self.top_hz = max(highest_excited_hz(self.harmonics, r) for r in self.speeds)
        #: the scale of the constraints: the lowest rotor frequency [Hz]
        self.f_scale = min(self.speeds) / 60.0

    def gaps_at(self, ev) -> dict:
        """{mode: (low, high)} of every excited mode of the evaluation ``ev`` (its damped frequency
        oscillating and at most :attr:`top_hz`), and of the lowest mode above: the gap it is kept
        in (that mode's is the one above the highest band, so that no mode enters the harmonics
        from above)."""
        freqs = {m: ev.value(damped_name(m)) for m in modes_of(ev)}
        below = [m for m, f in freqs.items() if 0.0 < f <= self.top_hz]
        above = [m for m, f in freqs.items() if f > self.top_hz]
        if above:
            below.append(min(above, key=lambda m: freqs[m]))
        return {m: allowed_gap(freqs[m], self.bands) for m in sorted(below)}

    def margin(self, f_hz: float) -> dict:
        """The least margin of one frequency over the operating speeds: harmonic_margin's row."""
        return min((harmonic_margin(f_hz, 0.0, r, self.harmonics) for r in self.speeds),
                   key=lambda m: m["margin_percent"])

    def state(self, ev, gaps: dict) -> dict:
        """The margin of the evaluation ``ev`` over the modes of ``gaps``: the least margin and its
        mode and harmonic, each mode's damped frequency and margin, and whether every mode lies in
        its gap to ``slack`` (the optimiser's feasibility tolerance)."""
        modes = {}
        for mode in gaps:
            f = ev.value(damped_name(mode))
            m = self.margin(f)
            modes[str(mode)] = {"damped_hz": f, "margin_percent": m["margin_percent"], "harmonic": m["harmonic"]}
        out = {"damped_hz": {k: v["damped_hz"] for k, v in modes.items()}, "modes": modes}
        if "f1_hz" in ev.values:
            out["f1_undamped_hz"] = ev.value("f1_hz")
        if modes:
            least = min(modes, key=lambda k: modes[k]["margin_percent"])
            out.update(margin_percent=modes[least]["margin_percent"], mode=int(least),
                       harmonic=modes[least]["harmonic"])
        return out

    def holds(self, ev, gaps: dict, errors: dict | None = None) -> bool:
        """Every mode of ``gaps`` lies in its gap (to 1e-9 of its edges: the resonance check's
        margin of a frequency on an edge is the required one to round-off), with its error bar
        (``errors``, :func:`error_bars`) inside it too."""
        def inside(m, lo, hi):
            lo, hi = _narrowed(lo, hi, (errors or {}).get(m, 0.0))
            return lo * (1.0 - 1e-9) <= ev.value(damped_name(m)) <= hi * (1.0 + 1e-9)
        return all(inside(m, lo, hi) for m, (lo, hi) in gaps.items())

    def rows(self, ev, gaps: dict, span: np.ndarray, width: int, tolerance: float,
             errors: dict | None = None) -> tuple[list, list]:
        """g >= 0 and its rows of the scaled problem: per mode, f - low (when low > 0) and
        high - f (when high is finite), divided by f_scale; ``span`` the parameters' ranges and
        ``width`` the scaled vector's length.

        Each edge is moved into its gap by the optimiser's feasibility tolerance on the scaled
        frequency (``tolerance`` x f_scale: SLSQP's acc, trust-constr's gtol), so that an optimum
        on an edge holds the margin itself, not the margin less the optimiser's slack (which the
        resonance check would flag: 9.9998 % < 10 %).  ``errors`` ({mode: error bar [Hz]},
        :func:`error_bars`) moves each mode's edges in by its converged frequency's error bar: the
        resonance verdict judges a margin at the worst end of the error bar, and so does the design."""
        values, rows = [], []
        n = span.size
        inset = tolerance * self.f_scale
        for mode, (lo, hi) in gaps.items():
            lo, hi = _narrowed(lo, hi, (errors or {}).get(mode, 0.0))
            if hi - lo > 4.0 * inset:
                lo, hi = lo + inset if lo > 0.0 else lo, hi - inset
            name = damped_name(mode)
            if name not in ev.gradients:
                raise RunError(f"the damped frequency of mode {mode} has no sensitivity at this design: it does not "
                               "oscillate here or is repeated, so its frequency margin cannot be constrained")
            f = ev.value(name)
            d_f = np.concatenate([ev.grad(name) * span, np.zeros(width - n)])
            if lo > 0.0:
                values.append((f - lo) / self.f_scale)
                rows.append(d_f / self.f_scale)
            if np.isfinite(hi):
                values.append((hi - f) / self.f_scale)
                rows.append(-d_f / self.f_scale)
        return values, rows

    def summary(self) -> dict:
        """What the margin is judged against (summary['design']['frequency_margin'])."""
        return {"required_percent": self.required_percent, "operating_rpm": self.speeds,
                "excitation": self.excitation, "harmonics": self.harmonics, "highest_excited_hz": self.top_hz,
                "frequencies": "damped"}


def modes_of(ev) -> list[int]:
    """The modes whose damped frequency the evaluation holds, ascending."""
    return sorted(int(n[2:-3]) for n in ev.values if n.startswith("fd") and n.endswith("_hz") and n[2:-3].isdigit())


def discretisation_shift(modal_model, levels: int, modes: list[int], expected_order: float) -> dict:
    """{mode: (shift, error)}: each mode's damped frequency f(converged) - f(n) [Hz] and the
    Richardson error estimate of the converged value, from the modal analysis of ``modal_model``
    (a modal deck at the design; a flight's hover state) at n, 2n (, 4n) bodies.  A mode that
    does not oscillate at every level has no shift (absent from the result)."""
    from pydriver.analyses.modal import modal_analysis
    from pydriver.analyses.refinement import refined_deck
    from pydriver.model import Model
    deck = modal_model.deck
    freqs = [modal_model if f == 1 else Model(refined_deck(deck, f)) for f in (1, 2, 4)[:levels]]
    freqs = [np.asarray(modal_analysis(m).summary["damped_frequencies_hz"], float) for m in freqs]
    out = {}
    for mode in modes:
        values = [float(f[mode - 1]) if mode <= f.size else 0.0 for f in freqs]
        if not all(v > 0.0 for v in values):
            continue
        e = (richardson_two(*values, expected_order=expected_order) if levels == 2 else
             richardson(*values, expected_order=expected_order))
        out[mode] = (float(e.extrapolated - values[0]), float(e.error_estimate))
    return out
