"""Fatigue of a run's load history per joint: rainflow around the jacket, Miner damage, hotspots.

The cable is a round section under two-axis bending whose plane turns with the blade azimuth,
so the bending moment's magnitude is no fatigue signal: a moment reversing through zero keeps
one sign in magnitude and shows half its range.  Each joint's history is therefore resolved at
``&fatigue circumferential_points`` points around the jacket (the critical-plane method for
non-proportional bending; Socie & Marquis, *Multiaxial Fatigue*, SAE 2000, ch. 5): at the
point at angle phi from the child body's axis e1,

    strain:  eps(phi) = r (kappa_x sin phi - kappa_y cos phi)      (r = jacket radius)
    moment:  M(phi)   =     m_x sin phi - m_y cos phi

(kappa, m: bend vector per length and bending moment in the child's axes e1, e2, sampled by the
core).  Each point's history is rainflow counted (:mod:`pydriver.fatigue`, ``rainflow`` package,
ASTM E1049), each cycle's amplitude corrected for its mean if the deck asks (``&fatigue
mean_stress``, :mod:`pydriver.mean_stress`), and its Palmgren-Miner damage summed on the deck's
S-N curve (Basquin's, or a table: ``sn_file``); the joint's damage is that of its worst point.
Every point's damage and extremes are kept (:class:`JacketPoints`, the result's
``extra["fatigue_points"]``) for a usage spectrum, which adds them over its regimes.  With
24 points the worst point lies within 7.5 deg of the true worst direction, so its amplitude is at
least cos 7.5 deg = 0.991 of the true one (damage at least 0.93 of it for m = 8); the deck can
ask for more.

A flight run's record is one periodic revolution (closed before counting); a dynamic run's
record is counted as an open history, and its damage per hour is that of the record repeated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver import fatigue
from pydriver.analyses.common import REACTION_NAMES, joint_geometry
from pydriver.data_tables import read_columns, resolve
from pydriver.errors import DeckError
from pydriver.mean_stress import MeanStressCorrection, corrected


def sn_curve(deck) -> fatigue.SNCurve | fatigue.TabulatedSNCurve:
    """The deck's S-N curve: Basquin's (``sn_exponent``, ``sn_reference_amplitude``,
    ``sn_reference_cycles``) or the table of ``&fatigue sn_file`` (amplitude, cycles; log-log
    interpolated, :class:`pydriver.fatigue.TabulatedSNCurve`), with the endurance cut-off."""
    f = deck.values["fatigue"]
    if f["sn_file"]:
        path = resolve(f["sn_file"], deck.path)
        try:
            table = read_columns(path, ("amplitude", "cycles"), min_rows=2)
            return fatigue.TabulatedSNCurve(table["amplitude"], table["cycles"], f["sn_endurance_amplitude"],
                                            f["sn_exponent"])
        except ValueError as err:
            deck.fail("fatigue", "sn_file", f"{err} (an S-N table: columns amplitude and cycles, docs/model.md "
                                            "\"Fatigue\")")
    return fatigue.SNCurve(f["sn_exponent"], f["sn_reference_amplitude"], f["sn_reference_cycles"],
                           f["sn_endurance_amplitude"])


def curve_text(sn, unit: str) -> str:
    """The S-N curve in words (the fatigue description)."""
    if isinstance(sn, fatigue.TabulatedSNCurve):
        return sn.describe(" Nm" if unit == "Nm" else "")
    ref = f"{sn.reference_amplitude:g}" + (" Nm" if unit == "Nm" else "")
    return f"N = {sn.reference_cycles:g} (S_a/{ref})^-{sn.exponent:g}"


def mean_stress(deck) -> MeanStressCorrection:
    """The deck's mean-stress correction (``&fatigue mean_stress``; :mod:`pydriver.mean_stress`)."""
    f = deck.values["fatigue"]
    return MeanStressCorrection(f["mean_stress"], f["ultimate"], f["walker_gamma"])


def joint_arc_lengths(model) -> np.ndarray:
    """Arc length of every joint from clamp A [m] (joint j is where body j starts)."""
    lengths = model.description["bodies"].lengths
    return np.concatenate([[0.0], np.cumsum(lengths)[:-1]])


def jacket_components(ts: dict, joint: int, quantity: str, radius: float):
    """(a, b, scale) of joint j: the history at angle phi is scale (a sin phi - b cos phi)."""
    if quantity == "strain":
        return ts[f"kappa_x{joint}_1pm"], ts[f"kappa_y{joint}_1pm"], radius
    return ts[f"moment_x{joint}_Nm"], ts[f"moment_y{joint}_Nm"], 1.0


def circumferential_histories(ts: dict, joint: int, quantity: str, radius: float, points: int):
    """(angles [rad], histories (points, nt)) of the strain or bending moment around joint j."""
    phi = 2.0 * np.pi * np.arange(points) / points
    a, b, scale = jacket_components(ts, joint, quantity, radius)
    return phi, scale * (np.sin(phi)[:, None] * a[None, :] - np.cos(phi)[:, None] * b[None, :])


@dataclass
class JacketPoints:
    """Every point around every joint's jacket of one run: where it is and what its history
    does.  One entry per (joint, point), joint-major; the run's fatigue table takes each joint's
    worst point from it, and a usage spectrum (:mod:`pydriver.analyses.spectrum_damage`) adds
    the points' damages over its regimes and takes their extremes for the ground-air-ground
    cycle."""

    joint: np.ndarray                     #: joint number j (1 ... n)
    angle_deg: np.ndarray                 #: angle phi of the point from the child body's e1 [deg]
    damage_per_record: np.ndarray         #: Miner damage of the record (one revolution, or the run)
    closed_damage_per_record: np.ndarray  #: the damage of its closed (full) cycles alone
    minimum: np.ndarray                   #: smallest value of the point's history
    maximum: np.ndarray                   #: largest value
    first: np.ndarray                     #: its first value (a run from rest: the rest state)
    per_hour: float                       #: records per flight hour (a flight: revolutions per hour)

    @property
    def damage_per_hour(self) -> np.ndarray:
        """Damage per flight hour of each point: the record's damage times records per hour."""
        return self.damage_per_record * self.per_hour


def _point_history(ts, j, k, quantity, radius, points):
    phi = 2.0 * np.pi * np.arange(points) / points
    a, b, scale = jacket_components(ts, j, quantity, radius)
    return scale * (np.sin(phi[k]) * a - np.cos(phi[k]) * b)


def _cycles_at(model, ts, j, k, correction, periodic) -> fatigue.Cycles:
    """The (mean-stress corrected) cycles of point k around joint j."""
    f = model.deck.values["fatigue"]
    radius = 0.5 * joint_geometry(model)["diameter"][j - 1]
    history = _point_history(ts, j, k, f["sn_quantity"], radius, int(f["circumferential_points"]))
    return _corrected(model, fatigue.cycles(history, periodic=periodic), correction, j)


def _corrected(model, cyc, correction, j) -> fatigue.Cycles:
    try:
        return corrected(cyc, correction)
    except ValueError as err:
        raise DeckError(model.name, "fatigue", "ultimate", f"joint {j}: {err}") from None


def fatigue_points(model, ts: dict, periodic: bool) -> JacketPoints:
    """Every jacket point of every joint of a run's time series (:class:`JacketPoints`)."""
    f = model.deck.values["fatigue"]
    sn = sn_curve(model.deck)
    correction = mean_stress(model.deck)
    record = record_basis(model, ts, periodic)
    points = int(f["circumferential_points"])
    diameter = joint_geometry(model)["diameter"]
    columns = {name: np.empty((model.n_bodies, points)) for name in
               ("damage_per_record", "closed_damage_per_record", "minimum", "maximum", "first")}
    for j in range(1, model.n_bodies + 1):
        for k in range(points):
            # One point's history at a time: memory of one column whatever the point count.
            history = _point_history(ts, j, k, f["sn_quantity"], 0.5 * diameter[j - 1], points)
            cyc = _corrected(model, fatigue.cycles(history, periodic=periodic), correction, j)
            try:
                damage = fatigue.miner_damage(cyc, sn)
                # A periodic record is closed: every cycle is a full one.  An open record's half
                # cycles are its residue (a run-up's climb to flight speed), which a usage
                # spectrum counts in its ground-air-ground cycle instead.
                full = cyc.counts == 1.0
                closed = damage if periodic else fatigue.miner_damage(
                    fatigue.Cycles(cyc.ranges[full], cyc.means[full], cyc.counts[full]), sn)
            except ValueError as err:
                _out_of_range(model, f"joint {j}: {err}")
            row = (damage, closed, np.min(history), np.max(history), history[0])
            for name, value in zip(columns, row):
                columns[name][j - 1, k] = value
    joint = np.repeat(np.arange(1, model.n_bodies + 1), points)
    angle = np.tile(np.degrees(2.0 * np.pi * np.arange(points) / points), model.n_bodies)
    return JacketPoints(joint=joint, angle_deg=angle, per_hour=record["per_hour"],
                        **{name: value.ravel() for name, value in columns.items()})


def _joint_row(model, ts, j, sn, correction, record, periodic, jacket: JacketPoints):
    """The damage of joint j: its worst point around the jacket."""
    damages = jacket.damage_per_record[jacket.joint == j]
    k = int(np.argmax(damages))                      # the first of equal worst points
    cyc = _cycles_at(model, ts, j, k, correction, periodic)
    return {"joint": j, "angle_deg": float(jacket.angle_deg[jacket.joint == j][k]),
            "damage_per_record": float(damages[k]),
            "del_amplitude": fatigue.damage_equivalent_amplitude(cyc, sn.exponent, record["n_equivalent"]),
            "n_cycles": float(cyc.total)}


def record_basis(model, ts, periodic: bool) -> dict:
    """How the record maps to flight hours and to the DEL's equivalent cycle count."""
    if periodic:
        # Revolutions per hour of the built model's speed (CoreModel.update may have changed it
        # since the description was made).
        rpm = float(model.core.parameter("rotor.omega")[0]) * 60.0 / (2.0 * np.pi)
        return {"per_hour": 60.0 * rpm, "n_equivalent": 1.0, "equivalent": "1/rev",
                "record": "one periodic revolution"}
    duration = float(ts["t"][-1] - ts["t"][0])
    return {"per_hour": 3600.0 / duration, "n_equivalent": duration, "equivalent": "1 Hz",
            "record": f"the run's {duration:g} s, repeated"}


def _out_of_range(model, reason: str):
    """A damage or DEL beyond the float range: an S-N curve far from the loads' scale (units)."""
    f = model.deck.values["fatigue"]
    unit = "strain, -" if f["sn_quantity"] == "strain" else "bending moment, Nm"
    if f["sn_file"]:
        raise DeckError(model.name, "fatigue", "sn_file", f"{reason}; the S-N table of {f['sn_file']} is too far "
                                                          f"from the loads of this run: check its unit ({unit})")
    raise DeckError(model.name, "fatigue", "sn_reference_amplitude",
                    f"{reason}; sn_reference_amplitude = {f['sn_reference_amplitude']:g} ({unit}) with "
                    f"sn_exponent = {f['sn_exponent']:g} is too far from the loads of this run: check its unit "
                    "(&fatigue sn_quantity)")


#: The deck's &fatigue sn_quantity in the words of a reader.
_WORDS = {"strain": "jacket strain", "bending": "bending moment"}


def hotspot_text(sn_quantity: str, joint: int, arc_length_m: float, angle_deg: float) -> str:
    """What a hotspot is, in words: the quantity, the joint, how far along the cable and where on
    the jacket (the angle around the cable from the axis e1 of the body after the joint: the
    critical point of the module doc).  Shown in the summary, report.html and the limits."""
    return (f"{_WORDS.get(sn_quantity, sn_quantity)} at joint {joint} ({arc_length_m:.3f} m from clamp A), "
            f"worst point of the jacket at {angle_deg:.0f} deg from the body's e1 axis")


def fatigue_of_run(model, ts: dict, periodic: bool, jacket: JacketPoints | None = None) -> tuple[dict, dict]:
    """(summary['fatigue'], fatigue.csv columns) of a run's time series; ``jacket``: its
    :func:`fatigue_points`, if the caller has them already."""
    deck = model.deck
    f = deck.values["fatigue"]
    sn = sn_curve(deck)
    correction = mean_stress(deck)
    record = record_basis(model, ts, periodic)
    jacket = jacket if jacket is not None else fatigue_points(model, ts, periodic)
    arc = joint_arc_lengths(model)
    unit = "-" if f["sn_quantity"] == "strain" else "Nm"
    rows = []
    for j in range(1, model.n_bodies + 1):
        row = _joint_row(model, ts, j, sn, correction, record, periodic, jacket)
        damage_per_hour = row.pop("damage_per_record") * record["per_hour"]
        if not np.isfinite(damage_per_hour):
            _out_of_range(model, f"joint {j}: damage per hour exceeds the float range")
        row.update(arc_length_m=float(arc[j - 1]), damage_per_hour=damage_per_hour,
                   life_hours=1.0 / damage_per_hour if damage_per_hour > 0.0 else None)
        for qty, col in (("bending_Nm", f"bending{j}_Nm"), ("strain", f"strain{j}"),
                         ("torsion_Nm", f"torsion{j}_Nm"), ("axial_N", f"axial{j}_N")):
            for key, value in fatigue.envelope(ts[col]).items():
                row[f"{qty}_{key}"] = value
        rows.append(row)
    ranked = sorted(rows, key=lambda r: r["damage_per_hour"], reverse=True)
    hot = [{"rank": i + 1, "joint": r["joint"], "arc_length_m": r["arc_length_m"],
            "quantity": hotspot_text(f["sn_quantity"], r["joint"], r["arc_length_m"], r["angle_deg"]),
            "damage_per_hour": r["damage_per_hour"], "life_hours": r["life_hours"],
            "del_amplitude": r["del_amplitude"]} for i, r in enumerate(ranked[:int(f["hotspots"])])]
    clamp_loads = []
    for name in REACTION_NAMES[:12 if model.nc else 6]:
        cyc = fatigue.cycles(ts[name], periodic=periodic)
        clamp_loads.append({"quantity": name, "n_cycles": float(cyc.total),
                            "del_amplitude": fatigue.damage_equivalent_amplitude(cyc, sn.exponent,
                                                                                 record["n_equivalent"]),
                            **fatigue.envelope(ts[name])})
    once = "once per rotor revolution" if record["equivalent"] == "1/rev" else "once per second"
    summary = {"description": f"Miner damage on {curve_text(sn, unit)} of the {_WORDS[f['sn_quantity']]} at "
                              f"{int(f['circumferential_points'])} points around the jacket of each joint, rainflow "
                              f"over {record['record']}"
                              + (f", {correction.describe()}" if correction.active else "")
                              + f"; a damage-equivalent load (DEL) is the amplitude that, repeated {once}, does the "
                                "same damage",
               "sn_quantity": f["sn_quantity"], "unit": unit, "equivalent": record["equivalent"],
               "hotspots": hot, "clamp_loads": clamp_loads}
    columns = {key: [r[key] for r in rows] for key in rows[0]}
    return summary, columns
