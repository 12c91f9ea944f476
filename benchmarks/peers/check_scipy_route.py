"""Check the numpy model of scipy_route.py against the Fortran core at random states.

For each deck and a few random (q, v, t) - random angles near and far from the start, random
rates, t inside and outside the pulse window - compare M, k, G, Gdot v, g, the accelerations
and multipliers of eq. 3.55 (no Baumgarte terms) and the support wrenches with
``pydriver.core_probes.evaluate_model``.  Prints the largest difference of each quantity, absolute and
relative to the quantity's largest entry over all states (g is ~0 at the consistent start, so a
per-state relative measure would be meaningless there), and exits non-zero if any relative difference
exceeds 1e-10.

    .venv/bin/python benchmarks/peers/check_scipy_route.py [deck ...]

With ``--runs`` it also integrates the two dynamic decks with DOP853 at rtol = 1e-10 and
compares the CM positions and reactions at t_end with the project's own run
(``pydriver.run_deck``, IDA at the deck's tolerances); this takes two to three minutes.

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
"""

from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pydriver  # noqa: E402
from pydriver import core_probes as probes  # noqa: E402
from scipy_route import ChainModel  # noqa: E402

DECKS = ("inputs/six_link_dynamic.nml", "inputs/uh60_part2_decay.nml", "inputs/three_body.nml")
KEYS = ("M", "k", "G", "Gdot_v", "g", "vdot", "lambda", "wrenches")


def check(deck, n_states=6, seed=1):
    rng = np.random.default_rng(seed)
    sc = pydriver.scene(deck)
    model = ChainModel(sc)
    nq = sc.n_coords
    worst = {key: [0.0, 0.0] for key in KEYS}     # max abs diff, max |reference| over states
    for i in range(n_states):
        if i == 0:
            q, v = sc.q0.copy(), rng.normal(size=nq)
        elif i % 2:
            q, v = sc.q0 + 0.3 * rng.normal(size=nq), rng.normal(size=nq)
        else:
            q, v = rng.uniform(-np.pi, np.pi, nq), 3.0 * rng.normal(size=nq)
        t = rng.uniform(0.0, sc.t_end)
        if sc.pulse_body > 0 and i < 3:
            t = rng.uniform(*sc.pulse_window)         # inside the pulse window
        on = sc.pulse_body > 0 and sc.pulse_window[0] <= t < sc.pulse_window[1]
        ref = probes.evaluate_model(deck, q, v, t=t)
        ref["wrenches"] = ref["wrenches"].as_flat()      # F_A, M_A, F_B, M_B as the peer's 12 values
        tm = model.terms(q, v, on)
        qdd, lam = model.accelerations(tm, v, baumgarte=False)
        ours = {"M": tm["M"], "k": tm["k"], "vdot": qdd, "lambda": lam,
                "wrenches": model.wrenches(tm, qdd, lam)}
        if model.nc:
            ours.update(G=tm["G"], Gdot_v=tm["Gdot_v"], g=tm["g"])
        else:
            ours["wrenches"][6:] = 0.0
        for key in KEYS:
            if key not in ours:
                continue
            a, b = np.asarray(ours[key]), np.asarray(ref[key])
            if a.size == 0:
                continue
            diff = float(np.max(np.abs(a - b)))
            scale = float(np.max(np.abs(b)))
            worst[key][0] = max(worst[key][0], diff)
            worst[key][1] = max(worst[key][1], scale)
    return {key: (a, a / s if s > 0 else a) for key, (a, s) in worst.items()}


RUN_DECKS = ("inputs/six_link_dynamic.nml", "inputs/uh60_part2_decay.nml")


def compare_runs(decks=RUN_DECKS, method="scipy-DOP853", rtol=1e-10):
    """Differences of CM positions and reactions against the project's run: at t_end (as
    ``simulate`` returns them) and, over the whole run, the CM positions at every output time
    of the project (the UH-60 decay has died down to < 0.1 um at t_end, so the end values alone
    would hardly test it)."""
    from scipy_route import ChainModel, integrate, simulate

    names = ["FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z",
             "FB_x", "FB_y", "FB_z", "MB_x", "MB_y", "MB_z"]
    for deck in decks:
        ts = pydriver.run_deck(deck).timeseries
        sc = pydriver.scene(deck)
        n = sc.n_bodies
        cm_ts = np.stack([np.stack([ts[f"{c}{j + 1}"] for c in "xyz"], axis=-1)
                          for j in range(n)], axis=1)             # (nt, n, 3)
        cm_ref = cm_ts[-1]
        wr_ref = np.array([ts[k][-1] if k in ts else 0.0 for k in names])
        res = simulate(deck, method, rtol)
        dcm = np.abs(res["cm_end"] - cm_ref)
        dwr = np.abs(res["reactions_end"] - wr_ref)
        print(f"{deck}: {method} rtol {rtol:g} vs run_deck at t = {ts['t'][-1]:g} s "
              f"({res['status']}, nfev {res['nfev']}, cpu {res['cpu_s']:.1f} s)")
        print(f"  cm_end        max |diff| {dcm.max():9.2e} m   (body {np.argmax(dcm.max(axis=1)) + 1})")
        print(f"  reactions_end max |diff| {dwr[[0, 1, 2, 6, 7, 8]].max():9.2e} N, "
              f"{dwr[[3, 4, 5, 9, 10, 11]].max():9.2e} Nm  (largest entry {np.abs(wr_ref).max():.3g})")
        print(f"  max constraint violation {res['max_constraint_violation_m']:.2e} m")
        # whole trajectory at the project's output times
        model = ChainModel(sc)
        sols, status, _ = integrate(model, method.split("-", 1)[1], rtol, t_eval=ts["t"])
        y = np.concatenate([s.y for s in sols], axis=1).T
        cm = np.stack([model.kinematics(yy[:model.nq], yy[model.nq:])["cm"] for yy in y])
        d = np.abs(cm - cm_ts)
        motion = np.abs(cm_ts - cm_ts[0]).max()
        i = np.unravel_index(np.argmax(d), d.shape)
        print(f"  trajectory    max |diff| {d.max():9.2e} m over {len(ts['t'])} output times "
              f"(t = {ts['t'][i[0]]:g} s, body {i[1] + 1}); largest CM excursion {motion:.3g} m, "
              f"at t_end {np.abs(cm_ref - cm_ts[0]).max():.2g} m")


def main(decks):
    ok = True
    for deck in decks:
        worst = check(deck)
        print(f"{deck}:")
        for key, (a, r) in worst.items():
            if a == 0.0 and r == 0.0:
                continue
            print(f"  {key:9s} max abs diff {a:9.2e}   max rel diff {r:9.2e}")
            ok &= r < 1e-10
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    args = sys.argv[1:]
    runs = "--runs" in args
    args = [a for a in args if a != "--runs"]
    rc = main(args or DECKS)
    if runs:
        compare_runs()
    sys.exit(rc)
