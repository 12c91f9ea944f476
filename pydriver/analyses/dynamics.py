"""Dynamic run: IDA from the deck's start (or the equilibrium) to t_end, outputs every dt_out
and exactly at t_end, streamed in chunks (docs/model.md, "Stabilised DAE and IDA")."""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.clamp_reach import reach_error
from pydriver.analyses.common import REACTION_NAMES, base_summary, reactions, straight_zy_warnings
from pydriver.analyses.output_grid import is_segment_start, output_grid
from pydriver.analyses.record_columns import chunk_columns, column_names, coordinate_columns
from pydriver.analyses.singularity import ClosestApproach
from pydriver.analyses.statics import equilibrium, has_pulse
from pydriver.core import Wrenches
from pydriver.errors import DeckError, RunError
from pydriver.output import CSV_MAX_VALUES, TimeseriesWriter
from pydriver.progress import report
from pydriver.run_result import Result

#: Samples integrated and post-processed per call into the core (bounded memory per chunk).
CHUNK = 2000
#: Largest time series kept in memory as well as on disk [bytes]; a run without an output
#: directory that would need more is refused before it starts.
MEMORY_LIMIT = 1.0e9


def start_state(model):
    """(q0, v0) of the run: the deck's shape and rates, or rest in the equilibrium."""
    if model.deck["case.start"] == "equilibrium":
        q, _, _ = equilibrium(model)
        return q, np.zeros_like(q)
    return model.q0, model.v0


def dynamic_run(model, run_dir=None) -> Result:
    """The registry's run of ``analysis = 'dynamic'`` (pydriver.analyses.registry): the
    integration and its estimate of its own integration error
    (:mod:`pydriver.analyses.integration_error`)."""
    from pydriver.analyses.integration_error import dynamic_check
    result = dynamic_analysis(model, run_dir)
    dynamic_check(model, result, dynamic_analysis)
    return result


def dynamic_analysis(model, run_dir=None, restart=None) -> Result:
    """Integrate and sample; the time series streams into ``run_dir`` if given.  ``restart``
    (a :class:`pydriver.checkpoint.Checkpoint`) continues the run it was written by."""
    t_wall = time.perf_counter()
    s = model.deck.values["solver"]
    try:
        times, starts = output_grid(s["t_end"], s["dt_out"], s["checkpoint_interval"],
                                    restart.t if restart is not None else None)
    except ValueError as exc:
        model.deck.fail("solver", "checkpoint_interval" if restart is None else "t_end", str(exc))
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
    kept, energy, g_max, q_all = [], [], [], []
    cardan = ClosestApproach(model)
    if restart is not None:
        # The run being continued, as checked by pydriver.checkpoint.continuation: its whole
        # time series up to restart.t, which ends with restart.q, restart.v.
        first = starts.index(int(np.searchsorted(times, restart.t)))
        earlier = restart.record
        cardan.update(earlier["t"], np.radians(np.array([earlier[c] for c, _, _ in coordinate_columns(model)])))
        if writer is not None:
            writer.write(earlier)
        if in_memory:
            kept.append(earlier)
            q_earlier = np.zeros((len(earlier["t"]), model.nq))
            for c, _, i in coordinate_columns(model):
                q_earlier[:, i] = np.radians(earlier[c])
            q_all.append(q_earlier)
        energy.append(earlier["E_kin_J"] + earlier["E_pot_J"])
        g_max.append(earlier["g_max_m"])
        tail = [earlier]
        q_seg, v_seg = restart.q, restart.v
    else:
        first = 0
        q_seg, v_seg = start_state(model)
        tail = []
    stats = {}
    try:
        bounds = starts[first:] + [len(times) - 1]
        for a, b in zip(bounds[:-1], bounds[1:]):
            q_seg, v_seg, seg_stats = _segment(model, times[a:b + 1], q_seg, v_seg, a == 0 and restart is None,
                                               writer, in_memory, kept, q_all, energy, g_max, cardan, tail)
            stats = {k: stats.get(k, 0) + x for k, x in seg_stats.items()}
    finally:
        if writer is not None:
            writer.close()
    energy = np.concatenate(energy)
    g_max = np.concatenate(g_max)
    last = tail[-1]
    w_end = [float(last[n][-1]) if n in last else 0.0 for n in REACTION_NAMES]
    summary = base_summary(model, "dynamic", time.perf_counter() - t_wall)
    summary.update(solver=stats, linear_solver=model.linear_solver(),
                   vector_kernels=s["vector_kernels"], max_constraint_violation_m=float(np.max(g_max)) if model.nc else 0.0,
                   reactions=reactions(Wrenches.from_flat(w_end), model.nc > 0), t_end_s=float(times[-1]), n_samples=int(len(times)),
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
        from pydriver import checkpoint
        checkpoint.write(run_dir.path(checkpoint.FILE), model, float(times[-1]), q_seg, v_seg)
        result.files[checkpoint.FILE] = run_dir.out / checkpoint.FILE
    if restart is not None:
        summary["restarted_from"] = _restart_summary(model, restart)
        if not summary["restarted_from"]["same_as_uninterrupted_run"]:
            summary.setdefault("warnings", []).append(summary["restarted_from"]["note"])
    _decay(model, result)
    if "fatigue" in model.deck.groups:
        if timeseries is None:
            raise DeckError(model.name, "fatigue", "sn_exponent", "fatigue of a run too large to keep in memory "
                            "is not supported: a larger dt_out or a shorter t_end")
        from pydriver.analyses.fatigue_loads import fatigue_of_run, fatigue_points
        jacket = fatigue_points(model, timeseries, periodic=False)
        summary["fatigue"], columns = fatigue_of_run(model, timeseries, periodic=False, jacket=jacket)
        result.extra.setdefault("tables", {})["fatigue.csv"] = columns
        result.extra["fatigue_points"] = jacket      # every jacket point (a spectrum's run-up)
    if timeseries is not None:
        beta = np.array([np.min(np.abs(np.sin(np.radians(timeseries[f"beta{j + 1}_deg"]))))
                         for j in range(model.n_bodies)])
        warnings = straight_zy_warnings(model, np.degrees(np.arcsin(beta)))
        if warnings:
            summary.setdefault("warnings", []).extend(warnings)
    return result


def _segment(model, tk_all, q0, v0, include_start, writer, in_memory, kept, q_all, energy, g_max, cardan, tail):
    """Integrate one segment (a fresh IDA session from q0, v0 at tk_all[0]) over its output
    times; the start sample is written only for the run's first segment (every later one's is
    the previous segment's last).  Returns the state at its end and its solver statistics."""
    session = model.core.start(model.solver_settings(), float(tk_all[0]), q0, v0)
    q_good, t_good = session.q0, float(tk_all[0])
    try:
        for start in range(0, len(tk_all), CHUNK):
            tk = tk_all[start:start + CHUNK]
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
            v_good = v[:, -1]
            report(f"dynamic: t = {t_good:.4g} s")
            if start == 0 and not include_start:
                tk, q, v = tk[1:], q[:, 1:], v[:, 1:]
                if len(tk) == 0:
                    continue
            cardan.update(tk, q)
            cols = chunk_columns(model, tk, model.core.sample(tk, q, v), q, v)
            if writer is not None:
                writer.write(cols)
            if in_memory:
                kept.append(cols)
                q_all.append(q.T)
            energy.append(cols["E_kin_J"] + cols["E_pot_J"])
            g_max.append(cols["g_max_m"])
            tail[:] = [cols]
    finally:
        session.close()
    return q_good, v_good, dict(session.stats)


def _restart_summary(model, restart) -> dict:
    """Where a continuation started, and whether it is the uninterrupted run bit for bit: it is
    when that run starts IDA afresh at the very same double (a multiple of
    ``checkpoint_interval``, :mod:`pydriver.analyses.output_grid`); otherwise IDA's step
    history differs from there on, and so does the result, by the integration's tolerance."""
    s = model.deck.values["solver"]
    same = bool(s["checkpoint_interval"] > 0.0 and
                is_segment_start(s["t_end"], s["dt_out"], s["checkpoint_interval"], restart.t))
    if same:
        note = ("bit for bit the uninterrupted run (IDA starts afresh at t = "
                f"{restart.t:g} s in both); solver statistics are the continuation's")
    elif s["checkpoint_interval"] > 0.0:
        note = (f"continued from t = {restart.t:g} s, which is not a multiple of &solver checkpoint_interval = "
                f"{s['checkpoint_interval']:g} s: IDA starts afresh there and the uninterrupted run does not, "
                f"so the two differ by the integration's tolerance (rtol = {s['rtol']:g}), not bit for bit")
    else:
        note = (f"continued from t = {restart.t:g} s without &solver checkpoint_interval: IDA starts afresh "
                "there and the uninterrupted run does not, so the two differ by the integration's tolerance "
                f"(rtol = {s['rtol']:g}), not bit for bit")
    return {"directory": str(restart.directory), "t_s": restart.t, "same_as_uninterrupted_run": same,
            "note": note}


def _decay(model, result: Result):
    """Decay evaluation of a pulsed run (thesis section 5.4): the pulsed body's z."""
    body = model.deck["loads.pulse_body"]
    if not has_pulse(model) or result.timeseries is None:
        return
    from pydriver.signal import decay_analysis
    signal = f"z{body}"
    d = decay_analysis(result.timeseries["t"], result.timeseries[signal], signal, model.deck["loads.pulse_end"])
    result.summary["decay"] = d
    if "f_damped_hz" not in d:
        result.summary.setdefault("warnings", []).append(f"decay evaluation omitted: {d['note']}")
