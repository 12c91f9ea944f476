"""The outputs of a time history, a flight's periodic revolution or a dynamic run's record, and
how each one's derivative follows from the derivative of the history: the outputs whose design
sensitivities :mod:`pydriver.analyses.flight_sensitivities` and
:mod:`pydriver.analyses.dynamic_sensitivities` report (docs/model.md, "Design sensitivities of a
flight", item 4).

Each output is selected on the base history (the sample of an extreme, the rainflow cycle set,
the worst point around a joint's jacket) and that selection is held: the derivative is exact
between changes of the selection.
"""

from __future__ import annotations

import numpy as np

from pydriver import fatigue
from pydriver.analyses.common import REACTION_NAMES, joint_geometry
from pydriver.analyses.fatigue_loads import jacket_components, record_basis, sn_curve
from pydriver.analyses.record_columns import chunk_columns

#: Peak loads per joint: (quantity, time-series unit suffix, unit).
PEAK_LOADS = (("bending", "_Nm", "Nm"), ("axial", "_N", "N"), ("torsion", "_Nm", "Nm"), ("strain", "", "-"))


def _unit_of(name: str) -> str:
    return "N" if name.startswith("F") else "Nm"


class HistoryOutputs:
    """The outputs of a time history (a flight's revolution, or a dynamic run's record with
    ``periodic`` false) and, for each, how its derivative follows from the derivative of the time
    series (selection by the base run, held fixed)."""

    def __init__(self, model, ts, periodic: bool = True, worst_points=None, jacket_extremes: bool = False):
        """``worst_points``: per joint, the index of its worst point around the jacket as the
        run's own fatigue analysis found it (the same rule on the same series); None: found here.
        ``jacket_extremes``: also the extremes, first value and closed cycles' damage of that
        point's history (what a usage spectrum combines across regimes)."""
        self.periodic = periodic
        self.worst_points = worst_points
        self.jacket_extremes = jacket_extremes
        self.names, self.units, self.values, self.rules = [], [], [], []
        nb = model.n_bodies
        for name in REACTION_NAMES[:12 if model.nc else 6]:
            x = ts[name]
            for tag, k in (("max", int(np.argmax(x))), ("min", int(np.argmin(x)))):
                self._add(f"{name}_{tag}", _unit_of(name), float(x[k]), ("sample", name, k, 1.0))
        for qty, suffix, unit in PEAK_LOADS:
            for j in range(1, nb + 1):
                col = f"{qty}{j}{suffix}"
                x = ts[col]
                k = int(np.argmax(np.abs(x)))
                self._add(f"{qty}{j}_peak", unit, float(abs(x[k])), ("sample", col, k, float(np.sign(x[k]))))
                hi, lo = int(np.argmax(x)), int(np.argmin(x))
                self._add(f"{qty}{j}_amplitude", unit, 0.5 * float(x[hi] - x[lo]), ("range", col, hi, lo))
        if "fatigue" in model.deck.groups:
            self._fatigue(model, ts)

    def _add(self, name, unit, value, rule):
        self.names.append(name)
        self.units.append(unit)
        self.values.append(value)
        self.rules.append(rule)

    def _fatigue(self, model, ts):
        """Per joint: damage per flight hour and DEL at its worst point; DELs of the reactions."""
        f = model.deck.values["fatigue"]
        sn = sn_curve(model.deck)
        periodic = self.periodic
        record = record_basis(model, ts, periodic=periodic)
        points = int(f["circumferential_points"])
        phi = 2.0 * np.pi * np.arange(points) / points
        radius = 0.5 * joint_geometry(model)["diameter"]
        unit = "-" if f["sn_quantity"] == "strain" else "Nm"
        for j in range(1, model.n_bodies + 1):
            a, b, scale = jacket_components(ts, j, f["sn_quantity"], radius[j - 1])
            best = None
            for k in range(points) if self.worst_points is None else [self.worst_points[j - 1]]:
                x = scale * (np.sin(phi[k]) * a - np.cos(phi[k]) * b)
                damage = fatigue.miner_damage(fatigue.cycles(x, periodic=periodic), sn)
                if best is None or damage > best[0]:
                    best = (damage, k, x)
            damage, k, x = best
            cyc = cycle_set(x, periodic)
            signal = ("point", j, float(phi[k]))
            self._add(f"damage_per_hour{j}", "1/h", damage * record["per_hour"],
                      ("damage", signal, cyc, sn, record["per_hour"]))
            self._add(f"del_amplitude{j}", unit,
                      fatigue.damage_equivalent_amplitude(fatigue.cycles(x, periodic=periodic), sn.exponent,
                                                          record["n_equivalent"]),
                      ("del", signal, cyc, sn.exponent, record["n_equivalent"]))
            if self.jacket_extremes:
                self._jacket_extremes(j, x, signal, cyc, sn, record["per_hour"], unit)
        for name in REACTION_NAMES[:12 if model.nc else 6]:
            x = ts[name]
            self._add(f"del_{name}", _unit_of(name),
                      fatigue.damage_equivalent_amplitude(fatigue.cycles(x, periodic=periodic), sn.exponent,
                                                          record["n_equivalent"]),
                      ("del", ("column", name), cycle_set(x, periodic), sn.exponent, record["n_equivalent"]))

    def _jacket_extremes(self, j, x, signal, cyc, sn, per_hour, unit):
        """A usage spectrum's ground-air-ground cycle spans the point's extremes in every regime and
        its value at rest (a run-up's first sample); a run-up's closed cycles count apart from its
        residue (pydriver/analyses/spectrum_damage.py): their values and rules at the point."""
        hi, lo = int(np.argmax(x)), int(np.argmin(x))
        for name, k in ((f"jacket_max{j}", hi), (f"jacket_min{j}", lo), (f"jacket_first{j}", 0)):
            self._add(name, unit, float(x[k]), ("sample", signal, k, 1.0))
        full = cyc.counts == 1.0
        closed = CycleSet(cyc.start[full], cyc.end[full], cyc.counts[full])
        rule = ("damage", signal, closed, sn, per_hour)
        self._add(f"closed_damage_per_hour{j}", "1/h", 0.0, rule)
        self.values[-1] = float(self.frozen(lambda spec: x, None, rules=[rule])[0])

    def samples_used(self) -> np.ndarray:
        """The sample indices the outputs' derivatives read (:meth:`derivatives`): the extremes'
        samples and the reversal samples of the cycle sets held fixed.  Their derivatives are
        all the outputs need, so the sample function is differenced there only."""
        used = set()
        for rule in self.rules:
            if rule[0] == "sample":
                used.add(rule[2])
            elif rule[0] == "range":
                used.update(rule[2:4])
            else:
                used.update(rule[2].start.tolist())
                used.update(rule[2].end.tolist())
        return np.array(sorted(used), dtype=int)

    def frozen(self, signal_of, per_hour: float | None = None, rules=None) -> np.ndarray:
        """The outputs of another time series (``signal_of(spec)``) with this one's selection
        held: the samples of the extremes, the cycle set, the point around the jacket; with
        ``per_hour`` its own records per flight hour (another rotor speed).  Its derivative is
        what :meth:`derivatives` gives.  ``rules``: those instead of this one's."""
        rules = self.rules if rules is None else rules
        out = np.zeros(len(rules))
        for i, rule in enumerate(rules):
            kind = rule[0]
            if kind == "sample":
                _, col, k, sign = rule
                out[i] = sign * signal_of(_spec(col))[k]
            elif kind == "range":
                _, col, hi, lo = rule
                x = signal_of(("column", col))
                out[i] = 0.5 * (x[hi] - x[lo])
            else:
                _, spec, cyc, *rest = rule
                x = signal_of(spec)
                amp, _ = amplitudes(x, x, cyc)
                if kind == "damage":
                    sn, own_per_hour = rest
                    live = amp > sn.endurance_amplitude
                    out[i] = (own_per_hour if per_hour is None else per_hour) * float(np.sum(cyc.counts[live] * (amp[live] / sn.reference_amplitude)
                                                     ** sn.exponent)) / sn.reference_cycles
                else:
                    m, n_eq = rest
                    out[i] = (float(np.sum(cyc.counts * amp ** m)) / n_eq) ** (1.0 / m)
        return out

    def derivatives(self, signal_of, d_signal_of) -> np.ndarray:
        """d(output)/dp from ``d_signal_of(spec)`` (the derivative of a time-series signal) and
        ``signal_of(spec)`` (the signal itself)."""
        out = np.zeros(len(self.rules))
        for i, rule in enumerate(self.rules):
            kind = rule[0]
            if kind == "sample":
                _, col, k, sign = rule
                out[i] = sign * d_signal_of(_spec(col))[k]
            elif kind == "range":
                _, col, hi, lo = rule
                dx = d_signal_of(("column", col))
                out[i] = 0.5 * (dx[hi] - dx[lo])
            else:
                _, spec, cyc, *rest = rule
                x, dx = signal_of(spec), d_signal_of(spec)
                amp, d_amp = amplitudes(x, dx, cyc)
                if kind == "damage":
                    sn, per_hour = rest
                    live = amp > sn.endurance_amplitude
                    d_i = cyc.counts[live] * (amp[live] / sn.reference_amplitude) ** sn.exponent / sn.reference_cycles
                    # dD = sum m D_i / S_i dS_i (the cycle set held fixed)
                    out[i] = per_hour * float(np.sum(sn.exponent * d_i / amp[live] * d_amp[live]))
                else:
                    m, n_eq = rest
                    live = amp > 0.0
                    if np.any(live):
                        s_eq = (np.sum(cyc.counts[live] * amp[live] ** m) / n_eq) ** (1.0 / m)
                        out[i] = s_eq ** (1.0 - m) / n_eq * float(
                            np.sum(cyc.counts[live] * amp[live] ** (m - 1.0) * d_amp[live]))
        return out


def _spec(col) -> tuple:
    """The signal of a sample rule: a time-series column by name, or a signal spec (a jacket point)."""
    return col if isinstance(col, tuple) else ("column", col)


class CycleSet:
    """Rainflow cycles of a periodic signal with the sample indices of their reversals."""

    def __init__(self, start, end, counts):
        self.start, self.end, self.counts = start, end, counts


def cycle_set(x, periodic: bool = True) -> CycleSet:
    """The cycles of :func:`pydriver.fatigue.cycles` with their reversal samples.  Periodic: the
    closed history is x rotated to its maximum (``close_period``), so its sample i is the
    signal's sample (i0 + i) mod n.  Otherwise the history is x itself, its residue half cycles."""
    x = np.asarray(x, float)
    n, i0 = x.size, (int(np.argmax(x)) if periodic else 0)
    closed = fatigue.close_period(x) if periodic else x
    found = [(r, m, c, a, b) for r, m, c, a, b in fatigue.rainflow.extract_cycles(closed) if r > 0.0]
    if not periodic:
        arr = np.array([[a, b, c] for _, _, c, a, b in found]).reshape(-1, 3)
        return CycleSet(arr[:, 0].astype(int), arr[:, 1].astype(int), arr[:, 2])
    # Pair the half cycles over the same two extremes into full cycles (fatigue._pair_half_cycles).
    out, pending = [], {}
    for r, m, c, a, b in found:
        if c == 1.0:
            out.append([a, b, 1.0])
        elif (r, m) in pending:
            out[pending.pop((r, m))][2] = 1.0
        else:
            pending[(r, m)] = len(out)
            out.append([a, b, 0.5])
    if not out:
        return CycleSet(np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    arr = np.array(out)
    return CycleSet((i0 + arr[:, 0].astype(int)) % n, (i0 + arr[:, 1].astype(int)) % n, arr[:, 2])


def amplitudes(x, dx, cyc: CycleSet):
    """Cycle amplitudes S = |x_k - x_i|/2 and their derivatives at the fixed reversal samples."""
    diff = x[cyc.end] - x[cyc.start]
    return 0.5 * np.abs(diff), 0.5 * np.sign(diff) * (dx[cyc.end] - dx[cyc.start])


def history_signal(model, ts, spec, diameters=None) -> np.ndarray:
    """A time-series signal: a column, or the fatigue quantity at a point around joint j
    (``diameters``: the model's joint diameters, :func:`joint_geometry`, when the caller has them)."""
    if spec[0] == "column":
        return np.asarray(ts[spec[1]], float)
    _, j, phi = spec
    f = model.deck.values["fatigue"]
    d = joint_geometry(model)["diameter"] if diameters is None else diameters
    a, b, scale = jacket_components(ts, j, f["sn_quantity"], 0.5 * d[j - 1])
    return scale * (np.sin(phi) * a - np.cos(phi) * b)


def output_derivatives(model, plans, outputs: HistoryOutputs, ts: dict, t, q, v, sq, sv,
                       speed=None) -> list[np.ndarray]:
    """d(output)/dp of every plan from the state sensitivities: central differences of the core's
    sample function along (q + e s_q, v + e s_v, p + e) on the rebuilt models (no re-solve), fed
    to the outputs' rules (:meth:`HistoryOutputs.derivatives`).  ``t`` are the sample times,
    ``q``, ``v`` (nq, nt) the states and ``sq``, ``sv`` (nq, nt, np) their sensitivities.  Where
    ``speed[k]`` (the rotor speed p) the samples are at fixed blade azimuth: the model at p + e
    samples at the time t p / (p + e).  Only the samples the outputs read
    (:meth:`HistoryOutputs.samples_used`) are differenced; the derivative signals hold NaN
    elsewhere, which no output reads."""
    values = []
    used = outputs.samples_used()
    t, q, v, sq, sv = np.asarray(t, float)[used], q[:, used], v[:, used], sq[:, used, :], sv[:, used, :]
    n_samples = np.asarray(ts["t"]).size
    signals = {}

    def signal_of(spec):
        # The run's own signals are the same for every parameter: formed once.
        if spec not in signals:
            signals[spec] = history_signal(model, ts, spec)
        return signals[spec]

    for k, pl in enumerate(plans):
        runs = []
        for s, w, m in pl.points:
            mm = m or model
            qs, vs = q + s * pl.h * sq[:, :, k], v + s * pl.h * sv[:, :, k]
            tt = t * pl.parameter.value / (pl.parameter.value + s * pl.h) if speed is not None and speed[k] else t
            # The joint diameters once per model (the jacket points' signals read them).
            runs.append((w, mm, chunk_columns(mm, tt, mm.core.sample(tt, qs, vs), qs, vs),
                         joint_geometry(mm)["diameter"]))

        def d_signal(spec, runs=runs, h=pl.h, memo=dict()):
            # A column read by several outputs (its peak and amplitude) is differenced once.
            if spec not in memo:
                memo[spec] = np.full(n_samples, np.nan)
                memo[spec][used] = sum(w * history_signal(mm, c, spec, d) for w, mm, c, d in runs) / h
            return memo[spec]

        values.append(outputs.derivatives(signal_of, d_signal))
    return values
