"""The abbreviations and terms the reports use, explained in one table.

``report.html`` (and a sweep's report) ends with a glossary of the entries whose pattern occurs
on the page, so every abbreviation a page shows is explained there and nowhere else.  A new
abbreviation in a report gets its row here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class Term:
    """One glossary row: the term as shown, its explanation, and a regular expression that
    finds its use in a page's text."""

    term: str
    meaning: str
    pattern: str


GLOSSARY: tuple[Term, ...] = (
    Term("F_A, M_A, F_B, M_B; FA_x ... MB_z",
         "Force [N] and moment [Nm] that support A (the clamp at the start of the cable, on the hub or the "
         "airframe) or support B (the clamp at its end, on the blade) exerts on the cable; the moment is "
         "about the clamp point.  _x, _y, _z are the components in the frame the equations are written in "
         "(hub or inertial frame).",
         r"\b[FM]_?[AB]_[xyz]\b|\b[FM]_[AB]\b"),
    Term("max |.|",
         "The largest absolute value over the record (the last, periodic revolution of a flight run; the "
         "whole run otherwise) of the quantity before it: \"MB_z max |.|\" is the largest |MB_z|.",
         r"max \|\.\|"),
    Term("peak bending, torsion, axial, strain",
         "The largest absolute bending moment [Nm], torsional moment [Nm], axial force [N] or jacket strain "
         "[-] over all joints and the whole record.",
         r"peak (bending|torsion|axial|strain)"),
    Term("jacket strain",
         "Bending strain at the cable's outer surface (the jacket): the curvature at a joint times the "
         "jacket radius d/2.  0.01 = 1 %.",
         r"jacket strain|\bstrain\b"),
    Term("f1, f2 ...; fd1, fd2 ...",
         "Natural frequency [Hz] of mode 1, 2 ... without damping (f) and with it (fd, the damped "
         "frequency, from the eigenvalue's imaginary part).",
         r"\bf\d+\b|\bfd\d+\b|\bf\d+_hz\b|\bf1_damped_hz\b"),
    Term("zeta", "Damping ratio of a mode (fraction of critical damping), [-].", r"\bzeta\d*\b"),
    Term("k/rev (1/rev, 4/rev ...)",
         "k times the rotor's rotation frequency (rpm/60), the k-th rotor harmonic [Hz]: the frequencies at "
         "which a rotating blade excites the cable.",
         r"\d+/rev|k/rev"),
    Term("resonance margin",
         "Separation of a mode's frequency from the nearest rotor harmonic, in percent of the harmonic; "
         "the deck's &resonance margin_percent is the least required.",
         r"margin"),
    Term("S-N curve (Basquin)",
         "Cycles to failure N against amplitude S_a: N = N_ref (S_a/S_ref)^-m, with the reference point "
         "(S_ref, N_ref) and the exponent m of the deck's &fatigue group.",
         r"S-N|Basquin|S_ref|N_ref"),
    Term("Miner damage, damage per flight hour, life",
         "Palmgren-Miner sum of n_i / N_i over the rainflow-counted cycles (1 = failure), scaled to one "
         "flight hour; the life [h] is 1 / (damage per flight hour).",
         r"Miner|damage per flight hour|life \[h\]|\blife\b"),
    Term("rainflow",
         "The cycle count of a load history (ASTM E1049): each closed hysteresis loop is one cycle of its "
         "amplitude.",
         r"rainflow"),
    Term("worst point of the jacket at N deg from the body's e1 axis",
         "The point on the jacket's circumference where a joint's fatigue is worst (critical plane), as the "
         "angle around the cable from the axis e1 of the body after the joint (its first cross-section axis); "
         "each joint is counted at &fatigue circumferential_points points around.",
         r"worst point of the jacket|\d+ deg around"),
    Term("DEL (damage-equivalent load)",
         "The constant amplitude that, applied N_eq times, does the same Miner damage as the counted cycles "
         "on an S-N curve of exponent m: DEL = (sum n_i S_a,i^m / N_eq)^(1/m), in the unit of the signal "
         "(DEL FA_x in N, DEL strain in -).",
         r"\bDEL\b"),
    Term("repeated once per rotor revolution, once per second (1/rev-, 1 Hz-equivalent)",
         "The equivalent cycle count N_eq of a DEL: one cycle per rotor revolution for a flight run (the DEL "
         "is then an amplitude at the 1/rev frequency), one per second of a dynamic run.",
         r"1/rev-equivalent|1 Hz-equivalent|once per (rotor revolution|second)"),
    Term("usage spectrum, regime, share of the flight time",
         "The helicopter's use as fractions of its flight time spent in each flight state (a regime: hover, a "
         "forward speed, turns ...), with the flights and rotor starts per flight hour; the life over it sums "
         "each regime's damage weighted by its share (&spectrum).",
         r"usage spectrum|\bregimes?\b"),
    Term("ground-air-ground (GAG) cycle",
         "The one load cycle per flight from the cable at rest on the ground (rotor stopped) to the extremes "
         "of the flight and back: at each jacket point, from the lowest to the highest value of rest, run-up "
         "and every regime.",
         r"ground-air-ground|\bGAG\b"),
    Term("start-stops",
         "The rotor's run-ups from rest and run-downs: the closed cycles of the run-up record, counted twice "
         "per start (the run-down taken as the run-up reversed).",
         r"start-stops?"),
    Term("safe life, scatter factor",
         "The life divided by the scatter factor (&spectrum scatter_factor): the hours the part may serve.",
         r"safe life|scatter factor"),
    Term("mean-stress correction (Goodman, Gerber, Walker)",
         "A cycle of amplitude S_a about a mean S_m counted as the fully reversed amplitude of equal life: "
         "Goodman S_a/(1 - S_m/S_u), Gerber S_a/(1 - (S_m/S_u)^2), Walker S_max^(1-gamma) S_a^gamma "
         "(&fatigue mean_stress; S_u its ultimate value).",
         r"mean-stress|Goodman|Gerber|Walker"),
    Term("n; Richardson extrapolation",
         "n is the number of rigid bodies the cable is cut into.  Run at n, 2n, 4n, each number is "
         "extrapolated to n -> infinity assuming an error ~ (1/n)^p; the observed order p and the error "
         "estimate (+-, the distance of the extrapolated value from the finest) tell how far the finest "
         "run is from the converged value.",
         r"Richardson|\bn = \d"),
    Term("hub frame, inertial frame",
         "The axes the equations and the loads are written in: the hub frame turns with the rotor (about "
         "&rotor centre); the inertial frame is fixed (the deck's axes).",
         r"hub frame|inertial frame|\bhub\b"),
    Term("blade azimuth",
         "Rotor angle of the blade [deg], 0 with the blade pointing downstream.",
         r"azimuth"),
    Term("gamma, beta (γ, β)",
         "The thesis's two angles that orient a body (joint parametrisation 'zy', docs/model.md); "
         "gamma_deg and beta_deg in the tables, in degrees.",
         r"γ|gamma|\bbeta\b|beta_deg"),
    Term("&group key",
         "A key of the deck (a Fortran namelist): group &group, key name; the command rotorcable keys GROUP "
         "lists a group's keys, rotorcable keys KEY explains one.",
         r"&\w+ \w+"),
)


def used_terms(text: str) -> list[Term]:
    """The glossary rows whose pattern occurs in ``text`` (a page's visible text), in table order."""
    return [t for t in GLOSSARY if re.search(t.pattern, text)]
