"""Per-call cost of the dynamics and its derivatives: Pinocchio's RNEA and RNEA derivatives
against rotorcable's residual and dense iteration matrix (issue 39, item 4).

Pinocchio (``pip install pin``) is a benchmark peer only: neither pydriver nor the tests import
it.  The chains are the same size on both sides: body 1 clamped, bodies 2 ... n on joints of
one revolute joint per axis (zy: Rz then Ry, 2 (n - 1) coordinates; xyz: Rx, Ry, Rz,
3 (n - 1)), the UH-60 part 2 cable's length and mass (0.59 m, 0.313 kg) split over n bodies.

Timed on each side in the same run, their batches interleaved (a batch of Pinocchio's calls,
one of rotorcable's, ...: a slow phase of the shared machine falls on both alike; batches
of about a millisecond where a call allows, so that most of them run without losing the core
to another process, and the median over many batches):

* Pinocchio, from Python (its pybind call costs ``call_overhead_us``, the median of an RNEA on a
  model without joints; it is subtracted in the ratios): ``rnea`` (tau) and
  ``computeRNEADerivatives`` (dtau/dq, dtau/dv, M) at random (q, v, a); the median over
  batches of many calls.
* rotorcable, in a Fortran loop (``pydriver.core_probes.time_kernels``: no Python call in the
  loop; the median over batches), the chain of ``inputs/uh60_part2_decay.nml`` with n bodies
  (clamp B held, joint springs and dampers, gravity, the pulse: more physics than the peer's
  chain) at its consistent start: the GGL residual; d(res)/dq, d(res)/dv and M
  (``eom_derivatives``, Pinocchio's three matrices); the whole dense iteration matrix of
  2 nq + 2 nc rows as the integrator gets it, physics columns analytic (whole matrices, the
  run's since issue 39) and by one tangent sweep per column (before).  Every call is at a new
  time, so each pays for its own residual pass, as Pinocchio's derivatives do.

Each side checks its calls did the work: results finite; Pinocchio's dtau/dq, dtau/dv against
central differences of its RNEA (1e-6 of the largest entry) and its M against its CRBA
(1e-12); rotorcable's analytic iteration matrix against the tangent sweeps' (1e-12).

Run from the repository root::

    .venv/bin/python benchmarks/peers/pinocchio_derivatives.py [--sizes 11 44 200] [--batches 41]

writes ``benchmarks/results/pinocchio_derivatives.csv`` and prints the table of
``benchmarks/README.md``.  The target: the full Jacobian (analytic) <= 1.5x Pinocchio's RNEA
derivatives.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")   # one core each side: the machine's other core is not ours

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import NoWorkDone, prepared  # noqa: E402
from pydriver import core_probes as probes  # noqa: E402
from pydriver.study import override_deck  # noqa: E402

LENGTH, MASS, DIAMETER = 0.590, 0.313, 0.015   # the UH-60 part 2 cable (Table A.2)
JOINTS = {"zy": "zy", "xyz": "xyz"}
TARGET = 1.5


def pinocchio_chain(n: int, axes: str) -> pin.Model:
    """Body 1 clamped (its length puts joint 2 at L along z), then n - 1 bodies, each on one
    revolute joint per axis at its joint point, its mass on the last of them (CM at L/2)."""
    length, mass, radius = LENGTH / n, MASS / n, DIAMETER / 2
    inertia = pin.Inertia(mass, np.array([0.0, 0.0, length / 2]),
                          np.diag([mass * (length**2 + 3 * radius**2) / 12] * 2 + [mass * radius**2 / 2]))
    joint_types = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
    model, parent = pin.Model(), 0
    for body in range(1, n):
        for i, axis in enumerate(axes):
            place = pin.SE3(np.eye(3), np.array([0.0, 0.0, length if i == 0 else 0.0]))
            parent = model.addJoint(parent, joint_types[axis](), place, f"j{body}{axis}")
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    return model


def rotorcable_deck(n: int, joint: str, path: Path) -> Path:
    """inputs/uh60_part2_decay.nml with n bodies and the given joint (its start bend spread over
    them; xyz: twist springs of Table A.2's beta springs' order, no gamma springs)."""
    bend = 66.0 / (n - 1)
    changes = {"chain": {"n_bodies": str(n), "joint": f"'{joint}'"},
               "shape": {"gamma_deg": f"90.0, 90.0, {n - 2}*0.0", "beta_deg": f"70.0, {n - 1}*{bend:.6f}"},
               "loads": {"pulse_body": str(max(2, n // 2))}}
    if joint == "xyz":
        changes["springs"] = {"c_gamma": "0.0", "d_gamma": "0.0", "c_twist": "27.33", "d_twist": "0.0385"}
    return override_deck(ROOT / "inputs" / "uh60_part2_decay.nml", path, changes)


def batch_us(call, per_batch: int) -> float:
    """Wall time per call [us] of one batch of calls."""
    t0 = time.perf_counter()
    for _ in range(per_batch):
        call()
    return (time.perf_counter() - t0) / per_batch * 1e6


def pinocchio_calls(n: int, axes: str) -> tuple[dict, int]:
    """Pinocchio's timed calls on the chain (after checking its results) and its coordinates."""
    model = pinocchio_chain(n, axes)
    data = model.createData()
    rng = np.random.default_rng(n)
    q, v, a = 0.3 * rng.standard_normal(model.nq), rng.standard_normal(model.nv), rng.standard_normal(model.nv)
    tau = pin.rnea(model, data, q, v, a).copy()
    dq, dv, m = (x.copy() for x in pin.computeRNEADerivatives(model, data, q, v, a))
    m = np.triu(m) + np.triu(m, 1).T
    crba = pin.crba(model, data, q)
    crba = np.triu(crba) + np.triu(crba, 1).T
    if not all(np.all(np.isfinite(x)) for x in (tau, dq, dv, m)):
        raise NoWorkDone(f"pinocchio {axes} n={n}: non-finite result")
    if np.abs(m - crba).max() > 1e-12 * np.abs(crba).max():
        raise NoWorkDone(f"pinocchio {axes} n={n}: M of the derivatives is not the CRBA's")
    h = 1e-6
    for k in rng.choice(model.nv, size=min(6, model.nv), replace=False):
        e = np.zeros(model.nv)
        e[k] = h
        cq = (pin.rnea(model, data, q + e, v, a) - pin.rnea(model, data, q - e, v, a)) / (2 * h)
        cv = (pin.rnea(model, data, q, v + e, a) - pin.rnea(model, data, q, v - e, a)) / (2 * h)
        if np.abs(cq - dq[:, k]).max() > 1e-6 * np.abs(dq).max() or np.abs(cv - dv[:, k]).max() > 1e-6 * np.abs(dv).max():
            raise NoWorkDone(f"pinocchio {axes} n={n}: derivatives differ from RNEA's differences, column {k}")
    per = max(5, 3000 // n)
    empty = pin.Model()
    empty_data, none = empty.createData(), np.zeros(0)
    calls = {"pin_rnea_us": (lambda: pin.rnea(model, data, q, v, a), per),
             "pin_derivatives_us": (lambda: pin.computeRNEADerivatives(model, data, q, v, a), max(2, per // 10)),
             "call_overhead_us": (lambda: pin.rnea(empty, empty_data, none, none, none), per)}
    return calls, model.nv


def rotorcable_kernels(n: int, joint: str):
    """rotorcable's timed kernels on the chain (after checking its results): a function of no
    arguments giving one batch's times [us], and (nq, nc)."""
    with tempfile.TemporaryDirectory() as tmp:
        m, q0, v0, _ = prepared(rotorcable_deck(n, joint, Path(tmp) / "deck.nml"))
    y, yd = probes.consistent_ggl_state(m.core, q0, v0)
    zero = np.zeros((len(y), 1))
    whole, swept = (probes.iteration_matrix(m.core, y, yd, 1.0e3, zero, jacobian=method)["jacobian"]
                    for method in ("analytic", "tangent_sweeps"))
    if not (np.all(np.isfinite(whole)) and np.all(np.isfinite(swept))):
        raise NoWorkDone(f"rotorcable {joint} n={n}: non-finite iteration matrix")
    if np.abs(whole - swept).max() > 1e-12 * np.abs(swept).max():
        raise NoWorkDone(f"rotorcable {joint} n={n}: analytic and tangent-sweep matrices differ")
    keys = {"rc_residual_us": "residual_ns", "rc_derivatives_us": "derivatives_ns", "rc_jacobian_us": "jacobian_ns",
            "rc_jacobian_sweeps_us": "jacobian_sweeps_ns"}

    def batch():
        k = probes.time_kernels(m.core, y, yd, max(20, 4000 // n))
        if not np.all(np.isfinite(k["residual"])):
            raise NoWorkDone(f"rotorcable {joint} n={n}: non-finite residual")
        return {ours: k[theirs] / 1e3 for ours, theirs in keys.items()}
    return batch, m.nq, m.nc


def measure(n: int, joint: str, batches: int) -> dict:
    """Both codes' medians on one chain, their batches interleaved (pin, rotorcable, pin, ...),
    so that a slow phase of the machine falls on both alike."""
    pin_calls, nv = pinocchio_calls(n, joint)
    rc_batch, nq, nc = rotorcable_kernels(n, joint)
    if nv != nq:
        raise NoWorkDone(f"{joint} n={n}: {nv} Pinocchio coordinates, {nq} rotorcable's")
    times = {}
    for _ in range(batches):
        for key, (call, per) in pin_calls.items():
            times.setdefault(key, []).append(batch_us(call, per))
        for key, value in rc_batch().items():
            times.setdefault(key, []).append(value)
    return {"joint": joint, "n_bodies": n, "nq": nq, "nc": nc,
            **{key: float(np.median(values)) for key, values in times.items()}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[11, 44, 200])
    parser.add_argument("--joints", nargs="+", default=list(JOINTS), choices=list(JOINTS))
    parser.add_argument("--batches", type=int, default=41)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "pinocchio_derivatives.csv")
    args = parser.parse_args(argv)
    rows = []
    for joint in args.joints:
        for n in args.sizes:
            row = measure(n, joint, args.batches)
            pin_der = row["pin_derivatives_us"] - row["call_overhead_us"]
            row["jacobian_over_pin_derivatives"] = row["rc_jacobian_us"] / pin_der
            row["derivatives_over_pin_derivatives"] = row["rc_derivatives_us"] / pin_der
            row["residual_over_pin_rnea"] = row["rc_residual_us"] / (row["pin_rnea_us"] - row["call_overhead_us"])
            rows.append(row)
            print(f"{joint:3s} n={n:3d} nq={row['nq']:3d}: pin rnea {row['pin_rnea_us']:.2f} us, derivs "
                  f"{row['pin_derivatives_us']:.1f} us (call {row['call_overhead_us']:.2f} us) | rc residual "
                  f"{row['rc_residual_us']:.2f} us, derivs {row['rc_derivatives_us']:.1f} us, jacobian "
                  f"{row['rc_jacobian_us']:.1f} us (sweeps {row['rc_jacobian_sweeps_us']:.1f} us)", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("\n| joint | n | nq | Pinocchio RNEA [us] | rotorcable residual [us] | Pinocchio RNEA derivatives [us] "
          "| rotorcable d(res)/dq, dv, M [us] | rotorcable Jacobian, analytic [us] | ratio to Pinocchio "
          "| rotorcable Jacobian, tangent sweeps [us] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        verdict = "PASS" if r["jacobian_over_pin_derivatives"] <= TARGET else "FAIL"
        print(f"| {r['joint']} | {r['n_bodies']} | {r['nq']} | {r['pin_rnea_us']:.2f} | {r['rc_residual_us']:.2f} "
              f"| {r['pin_derivatives_us']:.1f} | {r['rc_derivatives_us']:.1f} | {r['rc_jacobian_us']:.1f} "
              f"| {r['jacobian_over_pin_derivatives']:.2f} ({verdict}) | {r['rc_jacobian_sweeps_us']:.1f} |")
    print(f"\nwritten: {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
