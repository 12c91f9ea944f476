"""Verification of the Exudyn peer (exudyn_route.py) against rotorcable.

1. Static sanity: uh60_part2_decay starts at its static equilibrium; with the pulse off the CMs
   must stay at their q0 positions (independent numpy kinematics of the scene).
2. Step sweep for both test decks: end CMs and end reactions against a tight-tolerance rotorcable
   run (the deck with rtol/atol tightened, written to a temporary directory) and against the
   deck as it is; observed order of convergence between neighbouring steps.

Usage (from the project root):
    .venv/bin/python benchmarks/peers/exudyn_verify.py [--steps 1e-2,5e-3,...] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import exudyn_route as er  # noqa: E402

import pydriver  # noqa: E402

DECKS = ("inputs/six_link_dynamic.nml", "inputs/uh60_part2_decay.nml")
REAC = ["FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z", "FB_x", "FB_y", "FB_z", "MB_x", "MB_y", "MB_z"]


def cm_at_q0(sc):
    R = np.asarray(sc.base_rotation, float)
    P = np.asarray(sc.base_position, float)
    out = []
    for j in range(sc.n_bodies):
        if sc.locked[j]:
            g, b = sc.locked_angles[j]
        else:
            k = sc.first_coord[j] - 1
            g, b = sc.q0[k], sc.q0[k + 1]
        R = R @ er._rz(g) @ er._ry(b)
        out.append(P + R @ np.array([0.0, 0.0, 0.5 * sc.lengths[j]]))
        P = P + R @ np.array([0.0, 0.0, sc.lengths[j]])
    return np.array(out)


def rotorcable_end(deck, rtol=None, atol=None, t_at=None):
    """CMs and reactions of rotorcable at t_end (or at output time t_at); tolerances replaced in a
    temporary copy of the deck if given."""
    path = deck
    tmp = None
    if rtol is not None:
        text = open(deck).read()
        text = re.sub(r"(?m)^(\s*rtol\s*=\s*)\S+", rf"\g<1>{rtol}", text)
        text = re.sub(r"(?m)^(\s*atol\s*=\s*)\S+", rf"\g<1>{atol}", text)
        tmp = tempfile.TemporaryDirectory()
        path = os.path.join(tmp.name, os.path.basename(deck))
        with open(path, "w") as f:
            f.write(text)
    res = pydriver.run_deck(path)
    ts = res.timeseries
    n = res.summary["n_bodies"]
    i = -1 if t_at is None else int(np.argmin(np.abs(ts["t"] - t_at)))
    if t_at is not None and abs(ts["t"][i] - t_at) > 1e-12:
        raise ValueError(f"no rotorcable output at t = {t_at}")
    cm = np.array([[ts[f"{c}{j}"][i] for c in "xyz"] for j in range(1, n + 1)])
    reac = np.array([ts[k][i] for k in REAC])
    if tmp is not None:
        tmp.cleanup()
    return float(ts["t"][i]), cm, reac, res.summary["solver"]


def newton_contraction(deck, h=1e-3):
    """Contraction rho(I - J^-1 J_fd) of Exudyn's Newton after its first step, where J is Exudyn's
    iteration matrix and J_fd a finite-difference Jacobian of Exudyn's own Newton residual w.r.t.
    the Newton unknowns (Arnold/Bruels update: q -= d, v -= gamma' d, a -= beta' d,
    lambda -= d/(beta h^2)).  Also the ODE2-block mismatch with lambda set to 0."""
    import exudyn as exu

    sc = pydriver.scene(deck)
    m = er._Model(sc)
    mbs = m.mbs
    if m.load is not None:
        mbs.SetLoadParameter(m.load, "loadVector", list(sc.pulse_force))
    s = m.settings()
    s.timeIntegration.endTime = 1.0
    s.timeIntegration.numberOfSteps = int(round(1.0 / h))
    sol = exu.MainSolverImplicitSecondOrder()
    sol.InitializeSolver(mbs, s)
    sol.it.currentStepSize = h
    sol.UpdateCurrentTime(mbs, s)
    sol.InitializeStep(mbs, s)
    sol.ComputeNewtonUpdate(mbs, s, True)
    sd, C = mbs.systemData, exu.ConfigurationType.Current
    beta, gam, aM, aF = sol.newmarkBeta, sol.newmarkGamma, sol.alphaM, sol.alphaF
    bp, gp, sae = (1 - aM) / (h * h * beta * (1 - aF)), gam / (h * beta), 1.0 / (beta * h * h)

    def setstate(st):
        sd.SetODE2Coordinates(st[0], C)
        sd.SetODE2Coordinates_t(st[1], C)
        sd.SetODE2Coordinates_tt(st[2], C)
        sd.SetAECoordinates(st[3], C)

    def resid(st):
        setstate(st)
        sol.ComputeNewtonResidual(mbs, s)
        return np.array(sol.GetSystemResidual())

    def apply(st, d):
        n = len(st[0])
        return [st[0] - d[:n], st[1] - gp * d[:n], st[2] - bp * d[:n], st[3] - sae * d[n:]]

    def jacobians(st, eps=1e-7):
        r0 = resid(st)
        sol.ComputeNewtonJacobian(mbs, s)
        J = np.array(sol.GetSystemJacobian())
        Jfd = np.zeros_like(J)
        for k in range(len(r0)):
            d = np.zeros(len(r0))
            d[k] = eps
            Jfd[:, k] = -(resid(apply(st, d)) - r0) / eps
        return r0, J, Jfd

    st = [np.array(sd.GetODE2Coordinates(C)), np.array(sd.GetODE2Coordinates_t(C)),
          np.array(sd.GetODE2Coordinates_tt(C)), np.array(sd.GetAECoordinates(C))]
    for _ in range(3):                      # converge the first step with Exudyn's own matrix
        r0, J, _ = jacobians(st, eps=1.0)   # (eps irrelevant here; J is Exudyn's)
        st = apply(st, np.linalg.solve(J, r0))
    _, J, Jfd = jacobians(st)
    n = len(st[0])
    rho = float(np.abs(np.linalg.eigvals(np.eye(len(J)) - np.linalg.solve(J, Jfd))).max())
    mis = float(np.abs((J - Jfd)[:n, :n]).max())
    _, J0, Jfd0 = jacobians([st[0], st[1], st[2], np.zeros_like(st[3])])
    mis0 = float(np.abs((J0 - Jfd0)[:n, :n]).max())
    return rho, mis, mis0, float(np.abs(J[:n, :n]).max())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", default="1e-2,5e-3,2e-3,1e-3,5e-4,2e-4,1e-4,5e-5,2e-5,1e-5")
    ap.add_argument("--decks", default=",".join(DECKS))
    ap.add_argument("--userfunction", action="store_true",
                    help="also sweep the pulse as a load user function (no restart) for decks with a pulse")
    ap.add_argument("--t-compare", default="",
                    help="deck=time,...: compare at this output time instead of t_end, e.g. "
                         "inputs/uh60_part2_decay.nml=0.2 (just after the pulse, before the decay)")
    ap.add_argument("--newton-check", action="store_true",
                    help="only compare Exudyn's Newton matrix with a finite-difference Jacobian")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    steps = [float(s) for s in args.steps.split(",")]
    report = {"static": None, "sweeps": []}
    if args.newton_check:
        for deck in args.decks.split(","):
            rho, mis, mis0, jmax = newton_contraction(deck)
            print(f"{deck}: h=1e-3 Newton contraction rho(I - J^-1 J_fd) = {rho:.3g}; ODE2-block "
                  f"|J - J_fd| = {mis:.2e} (|J| = {jmax:.2e}), with lambda = 0: {mis0:.2e}")
        return

    # 1. static sanity
    deck = "inputs/uh60_part2_decay.nml"
    sc = pydriver.scene(deck)
    cm0 = cm_at_q0(sc)
    for h in (1e-3, 1e-4):
        r = er.simulate(deck, er.METHODS[0], h, t_end=0.05, pulse=False)
        drift = float(np.abs(r["cm_end"] - cm0).max())
        print(f"static sanity {deck} h={h:g} 0.05 s no pulse: status={r['status']} max CM drift = {drift:.2e} m"
              f", tip error {np.abs(r['tip_end'] - sc.clamp_position).max():.1e} m")
        report["static"] = {"deck": deck, "h": h, "max_cm_drift_m": drift,
                            "reactions": r["reactions_end"].tolist()}
    sys.stdout.flush()

    # 2. sweeps
    cases = [(d, None) for d in args.decks.split(",")]
    for item in filter(None, args.t_compare.split(",")):
        d, t = item.split("=")
        cases.append((d, float(t)))
    for deck, t_at in cases:
        t_ref, cm_ref, reac_ref, st_ref = rotorcable_end(deck, rtol="1.0e-11", atol="1.0e-11", t_at=t_at)
        t_dk, cm_dk, reac_dk, _ = rotorcable_end(deck, t_at=t_at)
        print(f"\n{deck}: rotorcable reference rtol=atol=1e-11 ({st_ref['steps']} IDA steps), compared at t={t_ref}; "
              f"deck tolerances differ from it by {np.abs(cm_dk - cm_ref).max():.1e} m (CM), "
              f"{np.abs(reac_dk - reac_ref).max():.1e} (reactions)")
        sc = pydriver.scene(deck)
        modes = ["restart"] + (["userfunction"] if args.userfunction and sc.pulse_body > 0 else [])
        for mode in modes:
            print(f"  pulse_mode={mode}" if sc.pulse_body > 0 else "  (no pulse)")
            print(f"  {'h':>8} {'steps':>7} {'rej':>4} {'newton':>7} {'jac':>6} {'cpu_s':>8} "
                  f"{'err_cm[m]':>10} {'order':>6} {'err_reac':>9} {'vs deck':>9}")
            prev = None
            for h in steps:
                r = er.simulate(deck, er.METHODS[0], h, pulse_mode=mode, t_end=t_at)
                if r["status"] != "ok":
                    print(f"  {h:8.0e} FAILED: {r['status']}")
                    report["sweeps"].append({"deck": deck, "t": t_ref, "mode": mode, "step": h,
                                             "status": r["status"]})
                    continue
                e = float(np.abs(r["cm_end"] - cm_ref).max())
                e_dk = float(np.abs(r["cm_end"] - cm_dk).max())
                er_ = float(np.abs(r["reactions_end"] - reac_ref).max())
                order = ""
                if prev is not None and e > 0 and prev[1] > 0:
                    order = f"{math.log(prev[1] / e) / math.log(prev[0] / h):6.2f}"
                prev = (h, e)
                print(f"  {h:8.0e} {r['n_steps']:7d} {r['rejected_steps']:4d} {r['newton_iterations']:7d} "
                      f"{r['jacobian_updates']:6d} {r['cpu_s']:8.3f} {e:10.2e} {order:>6} {er_:9.2e} {e_dk:9.2e}")
                sys.stdout.flush()
                report["sweeps"].append({
                    "deck": deck, "t": t_ref, "mode": mode, "step": h, "status": "ok",
                    "n_steps": r["n_steps"],
                    "rejected_steps": r["rejected_steps"], "newton_iterations": r["newton_iterations"],
                    "jacobian_updates": r["jacobian_updates"], "cpu_s": r["cpu_s"], "err_cm_m": e,
                    "err_cm_vs_deck_m": e_dk, "err_reactions": er_,
                    "err_reactions_each": np.abs(r["reactions_end"] - reac_ref).tolist()})
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
