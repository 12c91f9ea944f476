"""Dynamic run: IDA from the deck's start (or the equilibrium) to t_end, outputs every dt_out
and exactly at t_end, streamed in chunks (docs/model.md, "Stabilised DAE and IDA")."""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.clamp_reach import reach_error
from pydriver.analyses.common import RAD2DEG, REACTION_NAMES, base_summary, joint_columns, reactions, \
    straight_zy_warnings
from pydriver.analyses.singularity import ClosestApproach
from pydriver.analyses.statics import equilibrium
from pydriver.errors import DeckError, RunError
from pydriver.output import CSV_MAX_VALUES, TimeseriesWriter
from pydriver.progress import report
from pydriver.result import Result

#: Samples integrated and post-processed per call into the core (bounded memory per chunk).
CHUNK = 2000
#: Largest time series kept in memory as well as on disk [bytes]; a run without an output
#: directory that would need more is refused before it starts.
MEMORY_LIMIT = 1.0e9


def output_times(t_end: float, dt_out: float, t0: float = 0.0) -> np.ndarray:
    """t0, t0 + dt_out, ... and exactly t_end last (never beyond it, never short of it)."""
    n = int(np.floor((t_end - t0) / dt_out * (1.0 + 1e-12)))
    t = t0 + dt_out * np.arange(n + 1)
    if t[-1] < t_end - 1e-12 * max(abs(t_end), dt_out):
        t = np.append(t, t_end)
    t[-1] = t_end
    return t


#: Names of a joint's coordinates, in their order in q (docs/model.md: thesis gamma/beta, or
#: the Cardan bending angles about the joint's x and y axes, and the twist).
COORDINATE_NAMES = {"zy": ("gamma", "beta"), "xy": ("cardan_x", "cardan_y"),
                    "xyz": ("cardan_x", "cardan_y", "twist")}


def coordinate_columns(model) -> list[tuple[str, str, int]]:
    """(coordinate column, rate column, 0-based index in q) of every joint coordinate: the
    coordinates the springs act on, unwrapped (gamma{j}_deg wraps to +-180), and their rates."""
    names = COORDINATE_NAMES[model.deck["chain.joint"]]
    out = []
    for j, first in enumerate(model.description["first_coord"]):
        if first == 0:                      # a locked joint (a clamped first body) has none
            continue
        for k, name in enumerate(names):
            out.append((f"{name}{j + 1}_coord_deg", f"{name}{j + 1}_rate_degps", int(first) - 1 + k))
    return out


def column_names(model) -> list[str]:
    """The time-series columns of a dynamic run of this model."""
    nb = model.n_bodies
    names = ["t"]
    if model.description["rotor"] is not None:
        names += ["psi_deg", "azimuth_deg"]
    names += [f"{c}{j + 1}" for j in range(nb) for c in "xyz"]
    names += [f"{a}{j + 1}_deg" for j in range(nb) for a in ("gamma", "beta")]
    names += REACTION_NAMES if model.nc > 0 else REACTION_NAMES[:6]
    names += ["tip_x", "tip_y", "tip_z", "E_kin_J", "E_pot_J", "g_max_m"]
    names += [f"{q}{j + 1}_{u}" for j in range(nb) for q, u in
              (("axial", "N"), ("shear", "N"), ("bending", "Nm"), ("torsion", "Nm"), ("curvature", "1pm"))]
    names += [f"strain{j + 1}" for j in range(nb)]
    names += [f"{q}{j + 1}_{u}" for j in range(nb) for q, u in
              (("moment_x", "Nm"), ("moment_y", "Nm"), ("kappa_x", "1pm"), ("kappa_y", "1pm"))]
    coords = coordinate_columns(model)
    names += [c for c, _, _ in coords] + [r for _, r, _ in coords]
    return names


def chunk_columns(model, t, sample, q, v) -> dict:
    """One chunk's time-series columns from the core's samples and the coordinates q, v
    (nq, len(t)) they were taken at."""
    nb = model.n_bodies
    cols = {"t": np.asarray(t, float)}
    rot = model.description["rotor"]
    if rot is not None:
        cols["psi_deg"] = np.mod(sample["psi"] * RAD2DEG, 360.0)
        cols["azimuth_deg"] = np.mod((sample["psi"] + rot["azimuth0"]) * RAD2DEG, 360.0)
    for j in range(nb):
        for c, name in enumerate("xyz"):
            cols[f"{name}{j + 1}"] = sample["cm"][c, j]
    for j in range(nb):
        cols[f"gamma{j + 1}_deg"] = sample["angles"][0, j] * RAD2DEG
        cols[f"beta{j + 1}_deg"] = sample["angles"][1, j] * RAD2DEG
    for i, name in enumerate(REACTION_NAMES[:12 if model.nc > 0 else 6]):
        cols[name] = sample["wrenches"][:, i]
    for c, name in enumerate(("tip_x", "tip_y", "tip_z")):
        cols[name] = sample["joints"][c, -1]
    cols["E_kin_J"] = sample["kinetic"]
    cols["E_pot_J"] = sample["potential"]
    cols["g_max_m"] = sample["g_max"]
    cols.update(joint_columns(model, sample))
    coords = coordinate_columns(model)
    for name, _, i in coords:
        cols[name] = np.asarray(q, float)[i] * RAD2DEG
    for _, name, i in coords:
        cols[name] = np.asarray(v, float)[i] * RAD2DEG
    return cols


def start_state(model):
    """(q0, v0) of the run: the deck's shape and rates, or rest in the equilibrium."""
    if model.deck["case.start"] == "equilibrium":
        q, _, _ = equilibrium(model)
        return q, np.zeros_like(q)
    return model.q0, model.v0


def dynamic_analysis(model, run_dir=None) -> Result:
    """Integrate and sample; the time series streams into ``run_dir`` if given."""
    t_wall = time.perf_counter()
    s = model.deck.values["solver"]
    times = output_times(s["t_end"], s["dt_out"])
    names = column_names(model)
    n_values = len(times) * len(names)
    in_memory = n_values * 8 <= MEMORY_LIMIT
    if run_dir is None and not in_memory:
        raise DeckError(model.name, "solver", "dt_out", f"{len(times)} output samples x {len(names)} columns "
                        f"= {n_values * 8 / 1e9:.1f} GB in memory: run with an output directory (--out), "
                        "which streams to disk, or choose a larger dt_out")
    fmt = s.get("output_format", "auto")
    if fmt == "auto":
        fmt = "csv" if n_values <= CSV_MAX_VALUES else "hdf5"
    writer = None
    if run_dir is not None:
        fname = "timeseries.csv" if fmt == "csv" else "timeseries.h5"
        writer = TimeseriesWriter(run_dir.path(fname), names, fmt)
    q0, v0 = start_state(model)
    session = model.core.start(model.solver_settings(), float(times[0]), q0, v0)
    kept, energy, g_max, q_all = [], [], [], []
    cardan = ClosestApproach(model)
    q_good, t_good = session.q0, float(times[0])
    try:
        for start in range(0, len(times), CHUNK):
            tk = times[start:start + CHUNK]
            try:
                if start == 0:
                    q, v = session.advance(tk[1:])
                    q = np.column_stack([session.q0, q])
                    v = np.column_stack([session.v0, v])
                else:
                    q, v = session.advance(tk)
            except RunError as exc:
                # A support on the blade may have carried clamp B out of the cable's reach.
                raise reach_error(model, q_good, t_good, float(tk[-1]), exc) from exc
            q_good, t_good = q[:, -1], float(tk[-1])
            report(f"dynamic: t = {t_good:.4g} s of {float(times[-1]):.4g} s")
            cardan.update(tk, q)
            cols = chunk_columns(model, tk, model.core.sample(tk, q, v), q, v)
            if writer is not None:
                writer.write(cols)
            if in_memory:
                kept.append(cols)
                q_all.append(q.T)
            energy.append(cols["E_kin_J"] + cols["E_pot_J"])
            g_max.append(cols["g_max_m"])
    finally:
        session.close()
        if writer is not None:
            writer.close()
    stats = dict(session.stats)
    energy = np.concatenate(energy)
    g_max = np.concatenate(g_max)
    last = kept[-1] if kept else cols
    w_end = [float(last[n][-1]) if n in last else 0.0 for n in REACTION_NAMES]
    summary = base_summary(model, "dynamic", time.perf_counter() - t_wall)
    summary.update(solver=stats, linear_solver=model.linear_solver(), max_constraint_violation_m=float(np.max(g_max)) if model.nc else 0.0,
                   reactions=reactions(w_end, model.nc > 0), t_end_s=float(times[-1]), n_samples=int(len(times)),
                   energy_drift_rel=float(np.max(np.abs(energy - energy[0])) / max(abs(energy[0]), 1e-300)),
                   energy_J={"kinetic": float(last["E_kin_J"][-1]), "potential": float(last["E_pot_J"][-1])},
                   tip_m=[float(last[c][-1]) for c in ("tip_x", "tip_y", "tip_z")],
                   timeseries_format=fmt if writer is not None else "memory")
    if cardan.active:
        summary["cardan_singularity"] = cardan.summary()
        near = cardan.warnings()
        if near:
            summary.setdefault("warnings", []).extend(near)
    timeseries = {k: np.concatenate([c[k] for c in kept]) for k in names} if in_memory else None
    result = Result(summary=summary, timeseries=timeseries,
                    extra={"energy": energy, "constraint_violation": g_max,
                           "q": np.concatenate(q_all) if in_memory else None})
    if writer is not None:
        result.files[writer.path.name] = run_dir.out / writer.path.name
    _decay(model, result)
    if "fatigue" in model.deck.groups:
        if timeseries is None:
            raise DeckError(model.name, "fatigue", "sn_exponent", "fatigue of a run too large to keep in memory "
                            "is not supported: a larger dt_out or a shorter t_end")
        from pydriver.analyses.fatigue_loads import fatigue_of_run
        summary["fatigue"], columns = fatigue_of_run(model, timeseries, periodic=False)
        result.extra.setdefault("tables", {})["fatigue.csv"] = columns
    if timeseries is not None:
        beta = np.array([np.min(np.abs(np.sin(np.radians(timeseries[f"beta{j + 1}_deg"]))))
                         for j in range(model.n_bodies)])
        warnings = straight_zy_warnings(model, np.degrees(np.arcsin(beta)))
        if warnings:
            summary.setdefault("warnings", []).extend(warnings)
    return result


def _decay(model, result: Result):
    """Decay evaluation of a pulsed run (thesis section 5.4): the pulsed body's z."""
    body = model.deck["loads.pulse_body"]
    if body <= 0 or result.timeseries is None:
        return
    from pydriver.signal import decay_analysis
    signal = f"z{body}"
    d = decay_analysis(result.timeseries["t"], result.timeseries[signal], signal, model.deck["loads.pulse_end"])
    result.summary["decay"] = d
    if "f_damped_hz" not in d:
        result.summary.setdefault("warnings", []).append(f"decay evaluation omitted: {d['note']}")
