"""What a design optimisation minimises: the objective registry of ``&design objective``.

An objective is one :class:`Measure`: a name, what it means, the evaluation it needs and a
function giving its terms.  Each term is a smooth function of the design parameters with its
gradient (from :mod:`pydriver.analyses.sensitivities`, never finite differences of whole runs);
the objective is the largest term.  A largest-of-several is minimised in the epigraph form
(minimise t subject to t >= term_i, :mod:`pydriver.analyses.optimiser`), so the kink where two
terms swap does not stall a gradient method.

A new objective is one more entry of :data:`OBJECTIVES`.  A flight objective (``needs =
'flight'``) reads its terms from the flight sensitivities of the periodic revolution
(:mod:`pydriver.analyses.flight_sensitivities`): damage per flight hour with the rainflow cycle
set held fixed, strain amplitudes at their arg-max and arg-min samples.  The spectrum objective
(``needs = 'spectrum'``) reads the damage over a usage spectrum at each joint's worst point
(:mod:`pydriver.analyses.spectrum_design`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass
class Evaluation:
    """One evaluation of the deck at a parameter vector: output values and their gradients.

    Attributes
    ----------
    p : numpy.ndarray
        The parameters (deck units).
    values : dict
        Output name (as in sensitivities.csv: ``FA_z``, ``bending3_Nm``, ``f1_hz``) -> value.
    gradients : dict
        Output name -> d(output)/d(parameters), one entry per parameter.
    details : dict
        What the design report shows of this evaluation beyond the values (a usage spectrum's
        worst point and damage shares); empty for most.
    """

    p: np.ndarray
    values: dict
    gradients: dict
    details: dict = field(default_factory=dict)

    def value(self, name: str) -> float:
        return float(self.values[name])

    def grad(self, name: str) -> np.ndarray:
        return np.asarray(self.gradients[name], float)


def _magnitude(ev: Evaluation, names: list) -> tuple[float, np.ndarray]:
    """|v| of a vector of outputs and its gradient, v . dv / |v| (0 at v = 0, where |v| has no
    derivative and is never the largest term unless every term is 0)."""
    v = np.array([ev.value(n) for n in names])
    d = np.array([ev.grad(n) for n in names])
    size = float(np.linalg.norm(v))
    return size, (v @ d / size if size > 0.0 else np.zeros(d.shape[1]))


def _reaction_forces(ev: Evaluation):
    supports = [s for s in ("A", "B") if f"F{s}_x" in ev.values]
    return [_magnitude(ev, [f"F{s}_{c}" for c in "xyz"]) for s in supports]


def _joint_moments(ev: Evaluation):
    joints = sorted(int(n[len("bending"):-len("_Nm")]) for n in ev.values if n.startswith("bending"))
    return [_magnitude(ev, [f"bending{j}_Nm", f"torsion{j}_Nm"]) for j in joints]


def _per_joint(ev: Evaluation, prefix: str, suffix: str):
    """The terms ``prefix{j}{suffix}`` of every joint j, in joint order."""
    joints = sorted(int(n[len(prefix):len(n) - len(suffix)]) for n in ev.values
                    if n.startswith(prefix) and n.endswith(suffix) and n[len(prefix):len(n) - len(suffix)].isdigit())
    return [(ev.value(f"{prefix}{j}{suffix}"), ev.grad(f"{prefix}{j}{suffix}")) for j in joints]


def _damage_per_hour(ev: Evaluation):
    return _per_joint(ev, "damage_per_hour", "")


def _spectrum_damage_per_hour(ev: Evaluation):
    return _per_joint(ev, "spectrum_damage_per_hour", "")


def _strain_amplitude(ev: Evaluation):
    return _per_joint(ev, "strain", "_amplitude")


def _negative_first_frequency(ev: Evaluation):
    return [(-ev.value("f1_hz"), -ev.grad("f1_hz"))]


@dataclass(frozen=True)
class Measure:
    """One objective of the registry.

    Attributes
    ----------
    name : str
        The value of ``&design objective``.
    unit : str
    doc : str
        What it is, for the deck reference and docs/model.md.
    needs : str
        The evaluation it needs: ``'static'`` (equilibrium, reactions, joint loads), ``'modal'``
        (also the modes: the first undamped frequency), ``'flight'`` (the periodic revolution of a
        flight deck) or ``'spectrum'`` (every regime of the deck's usage spectrum and its run-up).
    terms : callable
        Evaluation -> list of (value, gradient); the objective is the largest value.
    """

    name: str
    unit: str
    doc: str
    needs: str
    terms: Callable

    def evaluate(self, ev: Evaluation) -> tuple[float, np.ndarray]:
        """The objective (the largest term) and the gradient of that term."""
        values = self.terms(ev)
        i = int(np.argmax([v for v, _ in values]))
        return values[i]


OBJECTIVES = {m.name: m for m in (
    Measure("max_reaction_force", "N",
            "the largest support force |F_A|, |F_B| of the static equilibrium (magnitude of the force vector)",
            "static", _reaction_forces),
    Measure("max_joint_moment", "Nm",
            "the largest joint moment of the static equilibrium, sqrt(bending^2 + torsion^2) over the joints",
            "static", _joint_moments),
    Measure("neg_first_frequency", "Hz",
            "minus the first undamped frequency about the equilibrium (minimised: the first frequency "
            "maximised)", "modal", _negative_first_frequency),
    Measure("max_damage_per_hour", "1/h",
            "the largest Miner damage per flight hour over the joints (each at its worst point around the jacket; "
            "&fatigue) of the periodic flight revolution: the shortest fatigue life maximised",
            "flight", _damage_per_hour),
    Measure("max_spectrum_damage_per_hour", "1/h",
            "the largest Miner damage per flight hour over the usage spectrum (&spectrum: every regime's damage "
            "weighted by its share of the flight time, the ground-air-ground cycles and the rotor's start-stops) over "
            "the joints, each at the worst point of its jacket: the life over the spectrum maximised",
            "spectrum", _spectrum_damage_per_hour),
    Measure("max_strain_amplitude", "-",
            "the largest jacket strain amplitude (max - min)/2 over the joints in the periodic flight revolution",
            "flight", _strain_amplitude),
)}


# -- the frequency margin constraint ---------------------------------------------------------------

def forbidden_bands(rpm_values: list, harmonics, margin_percent: float) -> list[tuple[float, float]]:
    """The frequency intervals a margin of ``margin_percent`` from every k/rev at the operating
    speeds forbids, merged where they overlap (at 10 % the bands of 5/rev and 6/rev meet:
    5 x 1.1 > 6 x 0.9).  ``harmonics``: K for k = 1 ... K, or the orders k themselves (the
    excited harmonics, :func:`pydriver.analyses.resonance.excited_harmonics`).  The margin is
    that of :mod:`pydriver.analyses.resonance`, |f - k Omega| / (k Omega)."""
    m = margin_percent / 100.0
    orders = range(1, int(harmonics) + 1) if np.ndim(harmonics) == 0 else [int(k) for k in harmonics]
    bands = sorted((k * r / 60.0 * (1.0 - m), k * r / 60.0 * (1.0 + m))
                   for r in rpm_values for k in orders)
    merged = []
    for lo, hi in bands:
        if merged and lo <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
        else:
            merged.append((lo, hi))
    return merged


def allowed_gap(f_hz: float, bands: list) -> tuple[float, float]:
    """The gap between forbidden bands a mode's frequency is kept in: the one holding ``f_hz``,
    or, from inside a band, the nearer side of it.  Crossing a harmonic is a discrete choice a
    gradient method cannot make; the designer moves the start to choose another gap."""
    edges = [0.0] + [x for band in bands for x in band] + [np.inf]
    gaps = [(edges[2 * i], edges[2 * i + 1]) for i in range(len(edges) // 2)]
    for lo, hi in gaps:
        if lo <= f_hz <= hi:
            return lo, hi
    for lo, hi in bands:
        if lo < f_hz < hi:
            below = next(g for g in gaps if g[1] == lo)
            above = next(g for g in gaps if g[0] == hi)
            return below if f_hz - lo < hi - f_hz else above
    raise AssertionError("the gaps and bands cover the positive axis")
