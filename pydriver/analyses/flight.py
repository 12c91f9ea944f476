"""Forward flight: integrate whole rotor revolutions until the motion is periodic (issue 12).

The run starts at rest relative to the hub in the equilibrium of the loads at t = 0 (the
quasi-static shape with the blade at its start azimuth and the stream on it) and integrates
one revolution T = 2 pi / Omega at a time.  The motion is periodic when two successive
revolutions differ by less than ``&solver periodic_tol`` (the largest distance between the
bodies' centres of mass at the same azimuth); the last revolution is reported (time series
with the azimuth, joint loads, reactions), and the number of revolutions it took.  A spent
budget (``max_revolutions``) is an error that says how far the motion was from periodic.
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.clamp_reach import reach_error
from pydriver.analyses.common import REACTION_NAMES, base_summary, reactions, rotor_period
from pydriver.analyses.fatigue_loads import fatigue_of_run, fatigue_points
from pydriver.analyses.record_columns import chunk_columns
from pydriver.analyses.shooting import periodic_start
from pydriver.analyses.singularity import ClosestApproach
from pydriver.analyses.statics import equilibrium
from pydriver.core import Wrenches
from pydriver.errors import RunError
from pydriver.output import TimeseriesWriter
from pydriver.progress import report
from pydriver.run_result import Result


def _peaks(model, ts: dict) -> dict:
    """The largest loads of the revolution: where along the cable and how large."""
    nb = model.n_bodies
    out = {}
    for qty, unit in (("bending", "Nm"), ("axial", "N"), ("torsion", "Nm"), ("strain", "")):
        cols = [f"{qty}{j + 1}_{unit}" if unit else f"{qty}{j + 1}" for j in range(nb)]
        data = np.column_stack([ts[c] for c in cols])
        k = np.unravel_index(np.argmax(np.abs(data)), data.shape)
        out[qty] = {"max_abs": float(np.abs(data[k])), "joint": int(k[1]) + 1,
                    "azimuth_deg": float(ts["azimuth_deg"][k[0]]),
                    "range_per_joint": [float(x) for x in np.ptp(data, axis=0)]}
    for name in REACTION_NAMES[:12 if model.nc else 6]:
        out[name] = {"min": float(np.min(ts[name])), "max": float(np.max(ts[name]))}
    return out


def flight_run(model, run_dir=None) -> Result:
    """The registry's run of ``analysis = 'flight'`` (pydriver.analyses.registry): the hover
    modes first (a march that cannot reach its periodic state is refused before it runs), the
    periodic revolution, its integration error estimate, the hover modes in the result and,
    with ``&solver floquet``, the Floquet stability of the revolution."""
    from pydriver.analyses.hover_modes import add_hover_modes, hover_modes, require_periodic_reachable
    from pydriver.analyses.integration_error import flight_check
    report("flight: the hover state's modes (how many revolutions marching needs)")
    hover = hover_modes(model)
    require_periodic_reachable(model, hover)
    result = flight_analysis(model, run_dir, hover)
    flight_check(model, result)
    add_hover_modes(model, result, hover)
    if "monodromy" in result.extra:
        report("flight: Floquet multipliers of the monodromy")
        from pydriver.analyses.floquet import add_floquet
        t_floquet = time.perf_counter()
        add_floquet(model, result, result.extra["monodromy"], result.extra["period_s"])
        # Floquet's own time: the monodromy's revolution with its columns and the eigenvalues.
        result.summary["floquet"]["wall_time_s"] = (result.extra["monodromy_wall_time_s"]
                                                    + time.perf_counter() - t_floquet)
    return result


def flight_analysis(model, run_dir=None, hover=None) -> Result:
    """Revolutions to a periodic steady state; the last one in detail.  ``hover``: the hover
    modes, when the caller has them (shooting steers by them; computed there otherwise)."""
    t_wall = time.perf_counter()
    s = model.deck.values["solver"]
    rot = model.description["rotor"]
    period = rotor_period(model)
    spr, tol = int(s["samples_per_rev"]), float(s["periodic_tol"])
    shooting = None
    if s["periodic_method"] == "shooting":
        q0, v0, shooting = periodic_start(model, period, tol, hover)
    else:
        q0, _, _ = equilibrium(model, t=0.0)
        v0 = np.zeros_like(q0)
    session = model.core.start(model.solver_settings(), 0.0, q0, v0)
    history, prev_cm = [], None
    cardan = ClosestApproach(model)
    q_last = v_last = None
    try:
        q_start, v_start = session.q0[:, None], session.v0[:, None]
        cardan.update([0.0], q_start)
        for rev in range(int(s["max_revolutions"])):
            t = period * (rev + np.arange(1, spr + 1) / spr)
            try:
                q, v = session.advance(t)
            except RunError as exc:
                # The blade may have carried clamp B out of the cable's reach: say so.
                raise reach_error(model, q_start[:, -1], period * rev, float(t[-1]), exc) from exc
            cardan.update(t, q)
            report(f"flight: revolution {rev + 1} of at most {int(s['max_revolutions'])}"
                   + (f", last difference {history[-1]:.2e} m (periodic_tol {tol:g} m)" if history else ""))
            cm = np.stack([model.core.shape(q[:, k], t[k])["cm"] for k in range(spr)])
            if prev_cm is not None:
                history.append(float(np.max(np.abs(cm - prev_cm))))
                if history[-1] < tol:
                    q_last = np.column_stack([q_start, q])
                    v_last = np.column_stack([v_start, v])
                    t_last = np.concatenate([[period * rev], t])
                    break
            prev_cm = cm
            q_start, v_start = q[:, -1:], v[:, -1:]
    finally:
        session.close()
    if q_last is None:
        last = f"{history[-1]:.3g} m" if history else "not measured"
        raise RunError(f"deck '{model.name}': no periodic steady state within {s['max_revolutions']} revolutions "
                       f"(two successive revolutions still differ by {last} > periodic_tol = {tol:g} m); "
                       "more revolutions (max_revolutions), more damping, or a looser periodic_tol")
    report("flight: loads at every joint over the periodic revolution")
    sample = model.core.sample(t_last, q_last, v_last)
    ts = chunk_columns(model, t_last, sample, q_last, v_last)
    files = {}
    if run_dir is not None:
        writer = TimeseriesWriter(run_dir.path("timeseries.csv"), list(ts), "csv")
        writer.write(ts)
        writer.close()
        files["timeseries.csv"] = run_dir.out / "timeseries.csv"
    summary = base_summary(model, "flight", time.perf_counter() - t_wall)
    w_end = [float(ts[n][-1]) if n in ts else 0.0 for n in REACTION_NAMES]
    summary.update(solver=dict(session.stats), linear_solver=model.linear_solver(),
                   vector_kernels=s["vector_kernels"], revolutions=len(history) + 1, period_s=period,
                   periodic_difference_m=history, periodic_tol_m=tol,
                   forward_speed_m_per_s=float(model.deck["drag.forward_speed"]) if "drag" in model.deck.groups
                   else 0.0,
                   max_constraint_violation_m=float(np.max(ts["g_max_m"])) if model.nc else 0.0,
                   reactions=reactions(Wrenches.from_flat(w_end), model.nc > 0), peaks=_peaks(model, ts),
                   n_samples=int(len(t_last)))
    if cardan.active:
        # Over every revolution integrated, not only the last one reported.
        summary["cardan_singularity"] = entry = cardan.summary()
        entry["revolution"] = max(1, int(np.ceil(entry["t_s"] / period - 1e-9)))
        entry["azimuth_deg"] = float(np.degrees(2.0 * np.pi * entry["t_s"] / period + rot["azimuth0"]) % 360.0)
        warnings = cardan.warnings(when=f"at t = {entry['t_s']:.4g} s (revolution {entry['revolution']}, "
                                        f"blade azimuth {entry['azimuth_deg']:.1f} deg)")
        if warnings:
            summary.setdefault("warnings", []).extend(warnings)
    summary["periodic_method"] = s["periodic_method"]
    if shooting is not None:
        summary["shooting"] = {"newton_iterations": shooting["iterations"],
                               "differences_m": shooting["differences_m"], "steps": shooting["steps"],
                               "method": "newton-picard", "newton_columns": shooting["newton_columns"],
                               "revolutions_integrated": shooting["iterations"] + summary["revolutions"]}
    extra = {"q": q_last.T, "shape_joints": sample.joints}
    # A start on the periodic orbit at t = 0 and, where one was taken there, its monodromy and the
    # basis of its coordinates (the design sensitivities, pydriver/analyses/flight_sensitivities.py).
    extra["orbit"] = {"q0": q_last[:, 0], "v0": v_last[:, 0]}
    extra["orbit"]["period_s"] = period
    if s["floquet"]:
        # The monodromy at the periodic state: one revolution with sensitivities from the start
        # of the last marched revolution (Floquet stability; shooting's Newton-Picard has none).
        report(f"flight: monodromy over one revolution ({2 * (model.nq - model.nc)} sensitivity columns, for "
               "the Floquet stability)")
        t_mono = time.perf_counter()
        mono = model.core.monodromy(model.solver_settings(), 0.0, q_last[:, 0], v_last[:, 0], [period])
        extra["monodromy_wall_time_s"] = time.perf_counter() - t_mono
        extra["monodromy"] = mono["phi"]
        extra["orbit"].update(q0=mono["q0"], v0=mono["v0"], phi=mono["phi"], basis=mono["basis"])
        extra["period_s"] = period
    if "fatigue" in model.deck.groups:
        report("flight: fatigue (rainflow around the jacket at every joint)")
        jacket = fatigue_points(model, ts, periodic=True)
        summary["fatigue"], columns = fatigue_of_run(model, ts, periodic=True, jacket=jacket)
        extra["tables"] = {"fatigue.csv": columns}
        extra["fatigue_points"] = jacket            # every jacket point, for a usage spectrum
    return Result(summary=summary, timeseries=ts, extra=extra, files=files)
