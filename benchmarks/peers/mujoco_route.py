"""MuJoCo peer for the work-precision benchmark: the UH-60 part 2 decay chain (thesis 5.4, the case
``uh60_part2_decay`` of benchmarks/work_precision.py) as an MJCF model, stepped by MuJoCo 4.0.

The scene (lengths, masses, principal inertias, joint axes, spring and damper constants and
rest angles, gravity, the 1 N pulse for 0.1 s, clamp B, the consistent start) comes from
``pydriver.scene``, exactly as for the Exudyn and SciPy peers; this module only writes it as MJCF:

* **Bodies and joints.**  rotorcable's free joint j is R_j = R_{j-1} Rz(gamma_j) Ry(beta_j) with
  the body frame's origin at the joint point P_j and z along the body.  In MuJoCo a body with
  several hinges applies them in the order written, each about its axis in the already rotated
  frame, so each body carries two hinges at its origin, ``axis="0 0 1"`` (gamma_j) then
  ``axis="0 1 0"`` (beta_j), with qpos0 = 0 (no ``ref``): qpos is rotorcable's q in the same
  order.  A child body sits at ``pos="0 0 L_{j-1}"`` in its parent.  The clamped body 1 cannot
  move: it is folded into the world (the first free body at P_2 = R_1 (0, 0, L_1), oriented R_1);
  its CM enters the CM samples as a constant.
* **Mass.**  ``<inertial pos="0 0 L/2" mass diaginertia>`` with the scene's principal inertia
  (eq. 4.50) in body axes; no geoms, contacts disabled (there is nothing to touch).
* **Springs/dampers.**  Joint ``stiffness``/``damping`` with ``springref`` = the scene's rest
  angle: MuJoCo's passive force -k (q - springref) - d qdot is rotorcable's per coordinate.
* **Gravity** ``<option gravity>``; **pulse**: ``xfrc_applied`` on the pulsed body, which MuJoCo
  applies at the body's CM in world axes (rotorcable's pulse acts at the CM too).  The window
  [0, 0.1) s is a whole number of steps and a sample interval boundary: the force is set before
  each block of steps, so it is piecewise constant with its edges on step boundaries, as
  rotorcable's IDA run stops at the edges.
* **Clamp B** (``mujoco-implicitfast-weld``): a ``<weld site1 site2>`` equality between a site at
  the tip (0, 0, L_n) of the last body (body axes) and a world site at clamp B's position and
  rotation; satisfied at q0 by construction.  MuJoCo constraints are soft: the weld's reference
  acceleration is a spring-damper with time constant ``solref[0]`` (asked 1e-6 s, MuJoCo raises
  it to 2 timesteps, "refsafe"; below that the run is unstable) and impedance ``solimp`` (dmin =
  dmax = 0.9999, the stiffest allowed).  The compliance is ~(1 - d)/d A tc^2 |lambda|, A the
  inverse inertia the constraint sees: the tip's position is held to ~6e-9 m at h = 1e-4 s, but
  the rotation rows see the links' tiny axial inertia (~1e-6 kg m^2), so the chain sags by
  3.3e-5 m at h = 1e-4 s and 1.3e-6 m at 2e-5 s (:func:`check_physics`), like h^2: that, not the
  integrator, sets this variant's error.  Newton solver, tolerance 1e-12.

Methods (accuracy knob = the fixed time step h; the solve is in C, ``mj_step(nstep=...)`` per
sample interval, so Python costs one call per 0.02 s block):

* ``mujoco-rk4-open``: the OPEN chain (clamp A fixed, end B free), MuJoCo's RK4.  This is a
  different and easier problem (no loop closure, no pre-stress): its error is measured against a
  rotorcable-IDA reference of the same open chain (the deck without ``&clamp_b``, start in its own
  static equilibrium, ``harness.open_chain_model``), computed the same way as the closed-chain
  reference (rtol = atol = 1e-12).  The ``uh60_part2_decay_open`` case of work_precision.py.
* ``mujoco-implicitfast-weld``: the CLOSED chain of the deck, clamp B as the stiff weld,
  MuJoCo's ``implicitfast`` integrator (implicit in the joint damping, semi-implicit Euler
  otherwise: first order).  Error against the deck's own reference.

:func:`check_physics` checks that the MJCF chain is the same physics: the generalized-force
balance at rotorcable's static equilibrium (open and closed), the drift of the closed chain from
that equilibrium without the pulse (static sag), and the first natural frequencies of the open
chain (MuJoCo's linearisation against rotorcable's modal analysis).
Run:  .venv/bin/python benchmarks/peers/mujoco_route.py   (the check, a few seconds)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import mujoco

import pydriver

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from harness import open_chain_model  # noqa: E402

METHODS = ("mujoco-rk4-open", "mujoco-implicitfast-weld")
# Which work_precision case (reference) each method is measured against.
CASE_OF = {"mujoco-rk4-open": "uh60_part2_decay_open", "mujoco-implicitfast-weld": "uh60_part2_decay"}
INTEGRATOR = {"mujoco-rk4-open": "RK4", "mujoco-implicitfast-weld": "implicitfast"}
WELD_SOLREF = (1e-6, 1.0)          # time constant [s] (raised to 2 h by MuJoCo), damping ratio
WELD_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
SOLVER_TOLERANCE = 1e-12
SAG_STEPS = (1e-4, 2e-5)
UNSTABLE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def _warn(message: str) -> None:
    print(f"MuJoCo warning: {message}", file=sys.stderr)


# MuJoCo's default warning handler also appends to MUJOCO_LOG.TXT in the working directory: a
# benchmark must not leave files behind, so its warnings go to stderr only (the runs that raise
# them are reported unstable by Chain.integrate).
mujoco.set_mju_user_warning(_warn)


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _quat(rotation) -> str:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation, float).reshape(9))
    return " ".join(repr(float(x)) for x in q)


def _vec(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def mjcf(sc, integrator: str, step: float, weld: bool) -> str:
    """The MJCF text of scene ``sc`` (see the module docstring for the mapping)."""
    n = sc.n_bodies
    if sc.rotor_omega != 0.0 or np.any(sc.tip_force != 0.0):
        raise NotImplementedError("rotating frame and tip force are not modelled")
    if np.any(sc.locked[1:]):
        raise NotImplementedError("only the first joint may be locked")
    if weld and not sc.clamp_active:
        raise ValueError("a weld needs clamp B in the deck")
    R = np.asarray(sc.base_rotation, float)
    P = np.asarray(sc.base_position, float)
    first = 0
    if sc.locked[0]:
        R = R @ _rz(sc.locked_angles[0, 0]) @ _ry(sc.locked_angles[0, 1])
        P = P + R @ np.array([0.0, 0.0, sc.lengths[0]])
        first = 1
    lines = ['<mujoco model="rotorcable_chain">',
             '  <compiler angle="radian" autolimits="true"/>',
             f'  <option timestep="{step!r}" integrator="{integrator}" gravity="{_vec(sc.gravity)}" '
             f'solver="Newton" tolerance="{SOLVER_TOLERANCE!r}" iterations="200">',
             '    <flag contact="disable" energy="enable"/>',
             '  </option>',
             '  <worldbody>']
    if weld:
        lines.append(f'    <site name="clamp_b" pos="{_vec(sc.clamp_position)}" quat="{_quat(sc.clamp_rotation)}"/>')
    indent = "    "
    for j in range(first, n):
        k = int(sc.first_coord[j]) - 1   # 1-based in the core
        pos = P if j == first else np.array([0.0, 0.0, sc.lengths[j - 1]])
        quat = _quat(R) if j == first else "1 0 0 0"
        lines.append(f'{indent}<body name="b{j + 1}" pos="{_vec(pos)}" quat="{quat}">')
        for c, axis in ((0, "0 0 1"), (1, "0 1 0")):
            lines.append(f'{indent}  <joint name="{"gb"[c]}{j + 1}" type="hinge" axis="{axis}" '
                         f'stiffness="{float(sc.stiffness[k + c])!r}" damping="{float(sc.damping[k + c])!r}" '
                         f'springref="{float(sc.rest[k + c])!r}"/>')
        lines.append(f'{indent}  <inertial pos="0 0 {0.5 * float(sc.lengths[j])!r}" mass="{float(sc.masses[j])!r}" '
                     f'diaginertia="{_vec(sc.inertia[j])}"/>')
        if j == n - 1 and weld:
            lines.append(f'{indent}  <site name="tip" pos="0 0 {float(sc.lengths[j])!r}"/>')
        indent += "  "
    for j in range(n - 1, first - 1, -1):
        indent = indent[:-2]
        lines.append(f"{indent}</body>")
    lines.append("  </worldbody>")
    if weld:
        lines += ["  <equality>",
                  f'    <weld site1="tip" site2="clamp_b" solref="{_vec(WELD_SOLREF)}" solimp="{_vec(WELD_SOLIMP)}"/>',
                  "  </equality>"]
    lines.append("</mujoco>")
    return "\n".join(lines)


class Chain:
    """A compiled MuJoCo model of a scene, its data at the scene's start, and the bookkeeping to
    read CM positions in rotorcable's body order."""

    def __init__(self, sc, integrator: str, step: float, weld: bool):
        self.sc = sc
        self.model = mujoco.MjModel.from_xml_string(mjcf(sc, integrator, step, weld))
        self.data = mujoco.MjData(self.model)
        if self.model.nq != sc.n_coords:
            raise RuntimeError(f"MJCF has {self.model.nq} coordinates, the scene {sc.n_coords}")
        self.first = 1 if sc.locked[0] else 0
        self.body_ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, f"b{j + 1}")
                         for j in range(self.first, sc.n_bodies)]
        self.cm1 = None
        if self.first:
            R1 = (np.asarray(sc.base_rotation, float) @ _rz(sc.locked_angles[0, 0])
                  @ _ry(sc.locked_angles[0, 1]))
            self.cm1 = np.asarray(sc.base_position, float) + R1 @ np.array([0.0, 0.0, 0.5 * sc.lengths[0]])
        self.pulse_id = (mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, f"b{sc.pulse_body}")
                         if sc.pulse_body > self.first else -1)
        self.reset()

    def reset(self, q=None, v=None):
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = self.sc.q0 if q is None else q
        self.data.qvel[:] = self.sc.v0 if v is None else v
        mujoco.mj_forward(self.model, self.data)

    def cms(self) -> np.ndarray:
        """(n, 3) centres of mass now (``xipos``; the clamped body 1 included)."""
        out = np.empty((self.sc.n_bodies, 3))
        if self.first:
            out[0] = self.cm1
        out[self.first:] = self.data.xipos[self.body_ids]
        return out

    def set_pulse(self, on: bool):
        if self.pulse_id >= 0:
            self.data.xfrc_applied[self.pulse_id, :3] = self.sc.pulse_force if on else 0.0

    def integrate(self, step: float, t_end: float, n_samples: int, pulse: bool = True):
        """Step 0 -> t_end in blocks of whole steps between the sample times and the pulse edges.

        Returns (cpu_s of the mj_step calls alone, steps, (n_samples, n, 3) CMs).

        Raises
        ------
        RuntimeError
            The run is unstable: MuJoCo found NaN/Inf/huge qpos, qvel or qacc (it then resets the
            state to qpos0 and goes on, so the samples would be finite but meaningless), or the
            energy above the start's grew in the free decay after the pulse (the open chain is
            passive and damped: only an unstable integration adds energy; RK4 just above its
            stability limit grows slowly without reaching MuJoCo's bound).  Not for the welded
            chain: MuJoCo's energy leaves out the soft weld's, and the chain's own energy drops
            by ~0.2 J as the weld gives way at large h."""
        n_total = round(t_end / step)
        if abs(n_total * step - t_end) > 1e-9 * t_end:
            raise ValueError(f"step {step} does not divide t_end {t_end}")
        edges = {0, n_total}
        for t in np.linspace(0.0, t_end, max(n_samples, 2)):
            k = round(t / step)
            if abs(k * step - t) > 1e-9:
                raise ValueError(f"step {step} does not divide the sample time {t}")
            edges.add(k)
        window = []
        if pulse and self.pulse_id >= 0:
            for t in self.sc.pulse_window:
                k = round(float(t) / step)
                if abs(k * step - t) > 1e-9:
                    raise ValueError(f"step {step} does not divide the pulse edge {t}")
                window.append(k)
                edges.add(min(max(k, 0), n_total))
        sample_steps = {round(t / step) for t in np.linspace(0.0, t_end, max(n_samples, 2))}
        edges = sorted(edges)
        samples = [self.cms()] if 0 in sample_steps else []
        energy_start = float(np.sum(self.data.energy))
        energy_after_pulse = None
        cpu = 0.0
        for a, b in zip(edges[:-1], edges[1:]):
            self.set_pulse(bool(window) and window[0] <= a < window[1])
            c0 = time.process_time()
            mujoco.mj_step(self.model, self.data, nstep=b - a)
            cpu += time.process_time() - c0
            bad = [w.name for w in UNSTABLE if self.data.warning[w].number > 0]
            if bad:
                raise RuntimeError(f"unstable at h = {step:g} s before t = {b * step:g} s "
                                   f"(MuJoCo {', '.join(bad)}; it resets the state)")
            if b in sample_steps or (window and b == window[1]):
                mujoco.mj_forward(self.model, self.data)      # xipos and energy of the new state
            if b in sample_steps:
                samples.append(self.cms())
            if window and b == window[1]:
                energy_after_pulse = float(np.sum(self.data.energy))
        if energy_after_pulse is not None and window[1] < n_total and self.model.neq == 0:
            excess_end = float(np.sum(self.data.energy)) - energy_start
            if excess_end > energy_after_pulse - energy_start:
                raise RuntimeError(f"unstable at h = {step:g} s: the energy above the start's grew in the free "
                                   f"decay, {energy_after_pulse - energy_start:.3e} J after the pulse, "
                                   f"{excess_end:.3e} J at t_end")
        return cpu, n_total, np.array(samples)


def simulate(deck_path, method: str, step: float, *, n_samples: int = 0) -> dict:
    """Integrate the decay chain of ``deck_path`` with ``method`` at fixed step ``step``.

    Parameters
    ----------
    deck_path : str or Path
        The closed-chain deck (``inputs/uh60_part2_decay.nml``); ``mujoco-rk4-open`` builds its
        open chain from it (``harness.open_chain_model``).
    method : str
        One of :data:`METHODS`.
    step : float
        Fixed time step [s]; must divide t_end, the sample interval and the pulse edges.
    n_samples : int
        Number of equally spaced sample times 0 ... t_end for ``cm_samples``.

    Returns
    -------
    dict
        ``status`` ("ok" or the error), ``cpu_s`` (process CPU time of the stepping alone),
        ``steps``, ``cm_end`` (n, 3), ``cm_samples`` (n_samples, n, 3), ``reactions_end`` (NaN:
        not measured for MuJoCo), ``weld_violation_m`` (largest tip distance from clamp B over
        the samples; weld only).
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; known: {METHODS}")
    weld = method.endswith("-weld")
    sc = pydriver.scene(deck_path if weld else open_chain_model(deck_path))
    out = {"status": "ok", "method": method, "step": float(step), "reactions_end": np.full(12, np.nan)}
    try:
        chain = Chain(sc, INTEGRATOR[method], float(step), weld)
        cpu, steps, samples = chain.integrate(float(step), float(sc.t_end), n_samples)
    except Exception as exc:  # noqa: BLE001 - a failed peer run is a data point
        return {"status": f"{type(exc).__name__}: {exc}"}
    if steps <= 0 or not np.all(np.isfinite(samples)):
        return {"status": f"no work done: {steps} steps, finite {bool(np.all(np.isfinite(samples)))}"}
    out.update(cpu_s=cpu, steps=steps, cm_end=samples[-1], cm_samples=samples)
    if weld:
        out["weld_violation_m"] = float(np.linalg.norm(chain.data.site_xpos[
            mujoco.mj_name2id(chain.model, mujoco.mjtObj.mjOBJ_SITE, "tip")] - sc.clamp_position))
    return out


def _generalized_balance(chain) -> float:
    """max |passive + constraint - bias| over the coordinates at the current state, relative to
    max |bias| (gravity's generalized force at rest): 0 in a static equilibrium."""
    d = chain.data
    residual = d.qfrc_passive + d.qfrc_constraint - d.qfrc_bias
    return float(np.max(np.abs(residual)) / np.max(np.abs(d.qfrc_bias)))


def open_frequencies(chain, h: float = 1e-7, count: int = 4) -> np.ndarray:
    """The first undamped natural frequencies [Hz] of MuJoCo's open chain linearised at its start:
    stiffness by central differences of the generalized forces (passive - bias at v = 0, step
    ``h`` rad: truncation ~h^2, round-off ~eps/h of forces ~1e-2, both far below the 1e-6
    agreement printed), the mass matrix by mj_fullM; eigenvalues of M^-1 K.  Undamped, as
    rotorcable's modal analysis reports them (its damped list has 0 for modes it finds
    overdamped in its modal damping, so the undamped ones are the comparable numbers)."""
    m, d = chain.model, chain.data
    q0 = chain.sc.q0.copy()
    nq = m.nq
    K = np.empty((nq, nq))
    for i in range(nq):
        f = []
        for s in (1.0, -1.0):
            q = q0.copy()
            q[i] += s * h
            chain.reset(q, np.zeros(nq))
            f.append(d.qfrc_passive - d.qfrc_bias)
        K[:, i] = -(f[0] - f[1]) / (2 * h)
    chain.reset(q0, np.zeros(nq))
    M = np.zeros((nq, nq))
    mujoco.mj_fullM(m, d, M)
    omega2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    return np.sqrt(np.maximum(omega2[:count], 0.0)) / (2 * np.pi)


def check_physics(deck_path) -> dict:
    """Is the MJCF chain the same physics as rotorcable's?  Prints and returns the numbers.

    * ``open_balance`` / ``closed_balance_h<h>``: the generalized-force balance (relative to
      gravity's generalized force) at rotorcable's static equilibrium for the open chain (round-off
      if the physics is the same), for the welded chain after 0.5 s without the pulse, where the
      weld's constraint force has taken up the pre-stress.
    * ``closed_sag_drift_m_h<h>``: the largest CM distance from rotorcable's equilibrium after
      0.5 s of the welded chain without the pulse, at the steps SAG_STEPS: how far MuJoCo's static
      sag is from rotorcable's.  The soft weld (time constant 2 h) gives way under the clamp
      moment, so this falls like h^2; it bounds the closed chain's error from below.
    * ``open_f_mujoco_hz`` / ``open_f_rotorcable_hz``: the first four undamped natural frequencies
      of the open chain, MuJoCo's linearisation against rotorcable's modal analysis.
    """
    out = {}
    open_model = open_chain_model(deck_path)
    so = pydriver.scene(open_model)
    chain = Chain(so, "RK4", 1e-4, weld=False)
    out["open_balance"] = _generalized_balance(chain)
    out["open_f_mujoco_hz"] = open_frequencies(chain)
    modal = pydriver.run_deck(open_model.with_changes({"case.analysis": "modal"}))
    out["open_f_rotorcable_hz"] = np.asarray(modal.summary["frequencies_hz"][:4])
    sc = pydriver.scene(deck_path)
    for h in SAG_STEPS:
        closed = Chain(sc, "implicitfast", h, weld=True)
        cm0 = closed.cms()
        closed.integrate(h, 0.5, 2, pulse=False)
        mujoco.mj_forward(closed.model, closed.data)
        out[f"closed_sag_drift_m_h{h:g}"] = float(np.max(np.linalg.norm(closed.cms() - cm0, axis=1)))
        out[f"closed_balance_h{h:g}"] = _generalized_balance(closed)
    print(f"MuJoCo {mujoco.__version__} vs rotorcable, UH-60 decay chain:\n"
          f"  open chain at rotorcable's equilibrium: |generalized force residual| / |gravity| = "
          f"{out['open_balance']:.1e}\n"
          f"  open chain first undamped frequencies [Hz]: MuJoCo {np.array2string(out['open_f_mujoco_hz'], precision=6)}"
          f", rotorcable {np.array2string(out['open_f_rotorcable_hz'], precision=6)}, largest relative "
          f"difference {np.max(np.abs(out['open_f_mujoco_hz'] / out['open_f_rotorcable_hz'] - 1)):.1e}"
          + "".join(f"\n  welded chain, h = {h:g} s, 0.5 s without the pulse from rotorcable's equilibrium: "
                    f"CMs move by at most {out[f'closed_sag_drift_m_h{h:g}']:.1e} m (the soft weld's "
                    f"compliance), force residual / gravity {out[f'closed_balance_h{h:g}']:.1e}"
                    for h in SAG_STEPS), flush=True)
    return out


if __name__ == "__main__":
    root = Path(__file__).resolve().parents[2]
    deck = sys.argv[1] if len(sys.argv) > 1 else root / "inputs" / "uh60_part2_decay.nml"
    check_physics(deck)
    for method, h in (("mujoco-rk4-open", 1e-4), ("mujoco-implicitfast-weld", 1e-4)):
        r = simulate(deck, method, h, n_samples=51)
        print(method, h, r["status"], r.get("cpu_s"), r.get("steps"), r.get("weld_violation_m"))
