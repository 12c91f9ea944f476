"""Exudyn peer for the work-precision benchmark: the rotorcable scene as an Exudyn model,
solved with Exudyn's default implicit generalized-alpha (index-3) dynamic solver.

The scene (bodies, joints, springs, clamps, loads, consistent start) comes from
``pydriver.scene(deck)``; everything below only *models* it in Exudyn (checked against the
Exudyn 1.13 item docstrings in ``exudyn.itemInterface``):

* **Minimal-coordinate tree.**  The open chain is one ``ObjectKinematicTree`` (Exudyn's
  Featherstone-type recursive tree on a ``NodeGenericODE2``).  Exudyn's tree joints have one
  axis each (``exu.JointType.RevoluteX/Y/Z``, ``PrismaticX/Y/Z``), so every free two-angle joint
  R_j = R_{j-1} Rz(gamma_j) Ry(beta_j) becomes two tree links: a massless intermediate link on a
  ``RevoluteZ`` joint (gamma_j) followed by the body on a ``RevoluteY`` joint (beta_j).  The
  tree's coordinates are then exactly rotorcable's q = (gamma_2, beta_2, gamma_3, ...), with
  reference coordinates 0 so node coordinates = joint angles.  A link's frame is the body frame
  (origin at the joint point P_j, z along the body), so the body's link has COM (0, 0, L_j/2) and
  the scene's principal inertia diag(I) about the CM in these axes; the next gamma link is offset
  by (0, 0, L_{j-1}) in its parent frame.
* **Clamped first body** (locked joint 1): it cannot move, so it is folded into the tree's base:
  the first free gamma link has parent -1, ``baseOffset`` = P_2 = P_1 + R_1 (0, 0, L_1) and joint
  transformation R_1 = R_0 Rz(gamma_1) Ry(beta_1) (the tree has no base rotation of its own; the
  root joint's transformation is in base = world axes).  Its weight only enters the reaction at A
  (added in the post-processing below).  A free first joint (pivot) simply gets R_0 and P_1.
* **Springs/dampers.**  The tree's joint PD terms are f_PD = P (u_o - q) + D (v_o - q_dot)
  (ObjectKinematicTree docs), so P = stiffness, u_o = rest, D = damping, v_o = 0 gives exactly
  rotorcable's -c (q - rest) - d q_dot per coordinate, and they are in the object's Jacobian.
* **Gravity** via the tree's ``gravity`` vector (LoadMassProportional is not available for trees).
* **Clamp B** (closing the loop): an ``ObjectJointGeneric`` with all six axes constrained between
  a ``MarkerKinematicTreeRigid`` at the tip (0, 0, L_n) of the last link (marker frame = body
  frame R_n) and a ground ``MarkerBodyRigid`` whose frame is localHT = (clamp_rotation,
  clamp_position): the joint holds the tip at p_B and R_n = R_B, satisfied at q0 by construction.
  Constraints are index 3 (Exudyn default, ``useIndex2Constraints = False``).
* **Pulse**: a ``LoadForceVector`` on a ``MarkerKinematicTreeRigid`` at the CM of the pulsed body
  (world frame, not body-fixed).  The rectangular window is handled like rotorcable's IDA run
  handles it (which stops exactly at the switching times and re-initialises): the solve is split
  into phases at the window edges, the constant load vector is switched between phases and the
  next ``SolveDynamic`` starts from the previous end state (``updateInitialValues=True``), with
  Exudyn's default ``computeInitialAccelerations`` giving consistent accelerations for the new
  load.  A time-dependent ``loadVectorUserFunction`` (the other natural Exudyn route,
  ``pulse_mode="userfunction"``) is kept for comparison: it makes the load jump *inside* the
  generalized-alpha history (the step ending at t = pulse_end sees F = 0, and the algorithmic
  accelerations carry the jump), which costs one O(h) error -- first-order convergence -- and
  calls Python at every residual.

Solver: ``exu.SolveDynamic`` with ``DynamicSolverType.GeneralizedAlpha`` defaults (spectral
radius 0.9, index 3, modified Newton with its default tolerances and default adaptive step
reduction on Newton failure -- no error-controlled step size exists for this solver), dense
linear solver, fixed step h = (t_b - t_a)/numberOfSteps per phase.  No renderer, no solution or
sensor files, verboseMode 0; only the end state is read (sensors evaluated on demand).

Reactions at t_end: F_B, M_B from the generic joint's Lagrange multipliers (``ForceLocal`` /
``TorqueLocal``; the latter are the raw multipliers of Exudyn's non-cyclic rotation constraints,
mapped to a moment below), converted to "support B acting on the chain"; F_A, M_A from the
Newton-Euler balance of the whole chain with Exudyn's end-of-step link accelerations (tree
sensors ``Acceleration``/``AngularAcceleration``/``AngularVelocity`` at each CM) and the weight of
the clamped body 1.  Both agree with rotorcable (static: F_A + F_B = total weight).

What Exudyn's default Newton does here (found while verifying; settings left at defaults):
the generalized-alpha iteration matrix (CSolverImplicitSecondOrder.cpp) is
beta' M + gamma' D + K + [C_q^T; C_q] without the derivative of the constraint forces
(C_q^T lambda)_q.  The UH-60 chain is strongly pre-stressed (|lambda_B| ~ 145 N) and its links
are light (axial inertia ~1e-6 kg m^2), so this term matters: comparing Exudyn's iteration matrix
with a finite-difference Jacobian of its own Newton residual (h = 1e-3) gives a Newton error
contraction rho(I - J^-1 J_fd) = 0.77 for UH-60 (8e-5 for the six-link chain), and the mismatch
drops 30x when lambda is set to 0.  So Newton converges only linearly there (with or without
modified Newton; ``doSystemWideDifferentiation`` / numerical AE Jacobians do not add the term),
hits the 25-iteration limit, and the default ``adaptiveStep`` halves the step: for h >= 1e-3 the
UH-60 runs settle at ~6e-4 s steps ("n_steps", "rejected_steps" report this).  From h <= 5e-4 every
step converges and the step is the fixed h.  The index-3 multipliers (and the accelerations)
carry round-off ~ eps/h^2, so the reactions are most accurate around h ~ 1e-4 .. 2e-4 and get
worse for smaller h, while the positions keep converging with order 2.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

import exudyn as exu
from exudyn.itemInterface import (LoadForceVector, MarkerBodyRigid, MarkerKinematicTreeRigid,
                                  NodeGenericODE2, ObjectGround, ObjectJointGeneric,
                                  ObjectKinematicTree, SensorKinematicTree)

import pydriver

METHODS = ("exudyn-genalpha",)

_OVT = exu.OutputVariableType


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _ht(rotation, translation):
    h = np.eye(4)
    h[:3, :3] = rotation
    h[:3, 3] = translation
    return h


class _Model:
    """An assembled Exudyn system of a scene, plus what is needed to read its end state."""

    def __init__(self, sc, pulse=True, pulse_mode="restart"):
        n = sc.n_bodies
        if sc.rotor_omega != 0.0:
            raise NotImplementedError("rotating frame (centrifugal loads) is not modelled")
        if np.any(sc.tip_force != 0.0):
            raise NotImplementedError("tip force is not modelled")
        if np.any(sc.locked[1:]):
            raise NotImplementedError("only the first joint may be locked")
        self.sc = sc
        self.SC = exu.SystemContainer()
        mbs = self.mbs = self.SC.AddSystem()

        # --- tree: (gamma link, body link) per free joint; a locked body 1 is the base -------
        R = np.asarray(sc.base_rotation, float)
        P = np.asarray(sc.base_position, float)
        first_free = 0
        if sc.locked[0]:
            R = R @ _rz(sc.locked_angles[0, 0]) @ _ry(sc.locked_angles[0, 1])
            P = P + R @ np.array([0.0, 0.0, sc.lengths[0]])
            first_free = 1
        self.first_free = first_free
        types, parents, rots, offs, inertias, coms, masses = [], [], [], [], [], [], []
        coord_of_link = []             # tree coordinate i <-> q index
        self.body_link = {}            # body j (0-based) -> tree link of the body
        for j in range(first_free, n):
            k = int(sc.first_coord[j]) - 1
            root = (j == first_free)
            # gamma: RevoluteZ, massless intermediate link
            types.append(exu.JointType.RevoluteZ)
            parents.append(-1 if root else len(types) - 2)
            rots.append(R if root else np.eye(3))
            offs.append([0.0, 0.0, 0.0] if root else [0.0, 0.0, sc.lengths[j - 1]])
            inertias.append(np.zeros((3, 3)))
            coms.append([0.0, 0.0, 0.0])
            masses.append(0.0)
            coord_of_link.append(k)
            # beta: RevoluteY, the body (frame origin P_j, axis z, CM at L/2)
            types.append(exu.JointType.RevoluteY)
            parents.append(len(types) - 2)
            rots.append(np.eye(3))
            offs.append([0.0, 0.0, 0.0])
            inertias.append(np.diag(sc.inertia[j]))
            coms.append([0.0, 0.0, 0.5 * sc.lengths[j]])
            masses.append(float(sc.masses[j]))
            coord_of_link.append(k + 1)
            self.body_link[j] = len(types) - 1
        nt = len(types)
        perm = np.array(coord_of_link)
        if nt != sc.n_coords or not np.array_equal(np.sort(perm), np.arange(nt)):
            raise RuntimeError("tree coordinates do not map onto the scene's q")
        self.perm = perm               # tree coordinate i is q[perm[i]]
        self.n_tree = nt

        self.node = mbs.AddNode(NodeGenericODE2(
            referenceCoordinates=[0.0] * nt,
            initialCoordinates=list(np.asarray(sc.q0)[perm]),
            initialCoordinates_t=list(np.asarray(sc.v0)[perm]),
            numberOfODE2Coordinates=nt))
        self.tree = mbs.AddObject(ObjectKinematicTree(
            nodeNumber=self.node, jointTypes=types, linkParents=parents,
            jointTransformations=exu.Matrix3DList(rots), jointOffsets=exu.Vector3DList(offs),
            linkInertiasCOM=exu.Matrix3DList(inertias), linkCOMs=exu.Vector3DList(coms),
            linkMasses=masses, baseOffset=list(P), gravity=list(np.asarray(sc.gravity, float)),
            jointPControlVector=list(np.asarray(sc.stiffness)[perm]),
            jointPositionOffsetVector=list(np.asarray(sc.rest)[perm]),
            jointDControlVector=list(np.asarray(sc.damping)[perm]),
            jointVelocityOffsetVector=[0.0] * nt))

        last = self.body_link[n - 1]
        # --- clamp B: generic joint, all 6 axes, tip marker <-> ground frame (p_B, R_B) -----
        self.joint = None
        if sc.clamp_active:
            ground = mbs.AddObject(ObjectGround())
            m_tip = mbs.AddMarker(MarkerKinematicTreeRigid(
                objectNumber=self.tree, linkNumber=last,
                localPosition=[0.0, 0.0, float(sc.lengths[n - 1])]))
            m_b = mbs.AddMarker(MarkerBodyRigid(
                bodyNumber=ground, localHT=_ht(sc.clamp_rotation, sc.clamp_position)))
            self.joint = mbs.AddObject(ObjectJointGeneric(
                markerNumbers=[m_tip, m_b], constrainedAxes=[1, 1, 1, 1, 1, 1]))

        # --- pulse ----------------------------------------------------------------------------
        self.load = None
        self.pulse_on = bool(pulse) and sc.pulse_body > 0
        self.pulse_mode = pulse_mode
        self.window = (float(sc.pulse_window[0]), float(sc.pulse_window[1]))
        self.pulse_force = np.asarray(sc.pulse_force, float)
        jp = sc.pulse_body - 1
        if self.pulse_on and jp >= first_free:
            m_p = mbs.AddMarker(MarkerKinematicTreeRigid(
                objectNumber=self.tree, linkNumber=self.body_link[jp],
                localPosition=[0.0, 0.0, 0.5 * float(sc.lengths[jp])]))
            if pulse_mode == "restart":
                self.load = mbs.AddLoad(LoadForceVector(markerNumber=m_p, loadVector=[0.0, 0.0, 0.0]))
            elif pulse_mode == "userfunction":
                t0, t1 = self.window
                f_on = [float(x) for x in self.pulse_force]

                def pulse_uf(mbs_, t, load_vector):
                    return f_on if t0 <= t < t1 else [0.0, 0.0, 0.0]

                self.load = mbs.AddLoad(LoadForceVector(markerNumber=m_p, loadVector=[0.0, 0.0, 0.0],
                                                        loadVectorUserFunction=pulse_uf))
            else:
                raise ValueError(f"pulse_mode {pulse_mode!r}")

        # --- end-state sensors (evaluated on demand only; solution.sensors.active = False) ----
        def sensor(link, pos, ovt):
            return mbs.AddSensor(SensorKinematicTree(
                objectNumber=self.tree, linkNumber=link, localPosition=list(pos), writeToFile=False,
                storeInternal=False, outputVariableType=ovt))
        self.s_cm, self.s_acc, self.s_rot, self.s_om, self.s_al = {}, {}, {}, {}, {}
        for j, link in self.body_link.items():
            cm = [0.0, 0.0, 0.5 * float(sc.lengths[j])]
            self.s_cm[j] = sensor(link, cm, _OVT.Position)
            self.s_acc[j] = sensor(link, cm, _OVT.Acceleration)
            self.s_rot[j] = sensor(link, cm, _OVT.RotationMatrix)
            self.s_om[j] = sensor(link, cm, _OVT.AngularVelocity)
            self.s_al[j] = sensor(link, cm, _OVT.AngularAcceleration)
        self.s_tip = sensor(last, [0.0, 0.0, float(sc.lengths[n - 1])], _OVT.Position)
        mbs.Assemble()

        # fixed body 1 (if clamped): CM and frame
        self.R1 = None
        if first_free == 1:
            R1 = np.asarray(sc.base_rotation, float) @ _rz(sc.locked_angles[0, 0]) @ _ry(sc.locked_angles[0, 1])
            self.R1 = R1
            self.cm1 = np.asarray(sc.base_position, float) + R1 @ np.array([0.0, 0.0, 0.5 * sc.lengths[0]])

    # ------------------------------------------------------------------------------------------
    def settings(self):
        s = exu.SimulationSettings()               # defaults: GeneralizedAlpha, rho_inf = 0.9, index 3
        s.solution.file.write = False              # (1.13 name of solutionSettings.writeSolutionToFile)
        s.solution.sensors.active = False
        s.solution.restart.write = False
        s.timeIntegration.verboseMode = 0
        s.timeIntegration.verboseModeFile = 0
        s.show.statistics = False
        s.show.computationTime = False
        s.show.globalTimers = False
        return s

    def solve(self, step, t_end, sample_times=()):
        """Integrate 0 -> t_end with step h; with ``sample_times`` the solve is also split at
        those times and the CMs there are kept in ``self.samples`` (time -> (n, 3)).

        Returns (cpu_s, accepted steps, Newton iterations, Jacobian updates, rejected tries).
        Exudyn's default ``adaptiveStep`` halves the step after a failed Newton (max 25 its) and
        grows it back to h later, so accepted steps can exceed (t_end / h).
        """
        sc, mbs = self.sc, self.mbs
        bounds = [0.0, t_end]
        if self.load is not None and self.pulse_mode == "restart":
            bounds += [t for t in self.window if 0.0 < t < t_end]
        bounds += [float(t) for t in sample_times if 0.0 < t < t_end]
        bounds = sorted(set(round(b, 12) for b in bounds))
        wanted = set(round(float(t), 12) for t in sample_times)
        self.samples = {}
        if 0.0 in wanted:
            self.samples[0.0] = self.cms()
        cpu = 0.0
        n_steps = newton = jacobians = rejected = 0
        s = self.settings()
        for a, b in zip(bounds[:-1], bounds[1:]):
            m = round((b - a) / step)
            if m < 1 or abs(m * step - (b - a)) > 1e-9 * max(1.0, b - a):
                raise ValueError(f"step {step} does not divide the phase [{a}, {b}]")
            if self.load is not None and self.pulse_mode == "restart":
                mid = 0.5 * (a + b)
                on = self.window[0] <= mid < self.window[1]
                mbs.SetLoadParameter(self.load, "loadVector", list(self.pulse_force if on else np.zeros(3)))
            s.timeIntegration.startTime = a
            s.timeIntegration.endTime = b
            s.timeIntegration.numberOfSteps = m
            c0 = time.process_time()
            exu.SolveDynamic(mbs, s, updateInitialValues=True, autoAssemble=False)
            cpu += time.process_time() - c0
            it = mbs.sys["dynamicSolver"].it
            n_steps += int(it.currentStepIndex) - 1          # accepted steps (index starts at 1)
            newton += int(it.newtonStepsCount)                # incl. iterations of rejected tries
            jacobians += int(it.newtonJacobiCount)
            rejected += int(it.rejectedModifiedNewtonSteps)
            if b in wanted:
                self.samples[b] = self.cms()
        return cpu, n_steps, newton, jacobians, rejected

    def cms(self):
        """Centres of mass now (sensors evaluated on demand; the clamped body 1 included)."""
        cms = np.zeros((self.sc.n_bodies, 3))
        for j in range(self.sc.n_bodies):
            cms[j] = self.cm1 if j < self.first_free else np.asarray(self.mbs.GetSensorValues(self.s_cm[j]))
        return cms

    # ------------------------------------------------------------------------------------------
    def end_state(self, t):
        """CMs, tip and reactions (support on chain, world frame; M_A about P_1, M_B about B)."""
        sc, mbs = self.sc, self.mbs
        n = sc.n_bodies
        g = np.asarray(sc.gravity, float)
        get = mbs.GetSensorValues
        cms = np.zeros((n, 3))
        F_in = np.zeros(3)       # sum m a - external forces (excluding supports)
        M_in = np.zeros(3)       # about A
        A = np.asarray(sc.base_position, float)
        for j in range(n):
            if j < self.first_free:
                c, a, Rm, om, al = self.cm1, np.zeros(3), self.R1, np.zeros(3), np.zeros(3)
            else:
                c = np.asarray(get(self.s_cm[j]))
                a = np.asarray(get(self.s_acc[j]))
                Rm = np.asarray(get(self.s_rot[j])).reshape(3, 3)
                om = np.asarray(get(self.s_om[j]))
                al = np.asarray(get(self.s_al[j]))
            cms[j] = c
            I_w = Rm @ np.diag(sc.inertia[j]) @ Rm.T
            f = sc.masses[j] * (a - g)
            if self.pulse_on and j == sc.pulse_body - 1 and self.window[0] <= t < self.window[1]:
                f = f - self.pulse_force
            F_in += f
            M_in += np.cross(c - A, f) + I_w @ al + np.cross(om, I_w @ om)
        tip = np.asarray(get(self.s_tip))
        if self.joint is not None:
            # Generic joint outputs (CObjectJointGeneric.cpp, all 6 axes locked): the Lagrange
            # multipliers.  Translations: g = p_1 - p_0 in world axes, ForceLocal = R_J0^T lambda,
            # and lambda is the force of the support on marker 0 (the chain tip).  Rotations:
            # g = (z0.y1, z0.x1, x0.y1), TorqueLocal = (lambda_3, lambda_4, lambda_5) raw; with the
            # frames coincident their gradients w.r.t. a rotation of marker 0 are (-x, +y, +z) in J0
            # axes, so the moment of the support on the chain is R_J0 diag(1, -1, -1) TorqueLocal.
            # J0 = tip marker frame = body frame R_n.  (Both checked against rotorcable.)
            Rn = np.asarray(get(self.s_rot[n - 1])).reshape(3, 3)
            fB = Rn @ np.asarray(mbs.GetObjectOutput(self.joint, _OVT.ForceLocal))
            mB = Rn @ (_TORQUE_SIGNS * np.asarray(mbs.GetObjectOutput(self.joint, _OVT.TorqueLocal)))
        else:
            fB = np.zeros(3)
            mB = np.zeros(3)
        fA = F_in - fB
        mA = M_in - mB - np.cross(tip - A, fB)
        return cms, tip, np.concatenate([fA, mA, fB, mB])


_TORQUE_SIGNS = np.array([1.0, -1.0, -1.0])


def simulate(deck_path: str, method: str, step: float, *, t_end: float | None = None,
             pulse: bool = True, pulse_mode: str = "restart", n_samples: int = 0) -> dict:
    """Integrate the deck's scene from its consistent start to t_end with fixed step `step`.

    Returns {"method", "step", "cpu_s" (time.process_time() around exu.SolveDynamic only, not
    model building), "cm_end": (n,3) CM positions at t_end [m] (clamped body 1 included),
    "tip_end": (3,) P_{n+1}, "reactions_end": (12,) F_A, M_A, F_B, M_B at t_end (support acting on
    the chain, inertial frame, moments about A=P_1 and B), "n_steps": int,
    "newton_iterations": int, "status": "ok" or the error}, plus "jacobian_updates" and
    "rejected_steps" (Newton failures that made Exudyn's default adaptiveStep cut the step).

    Keyword-only extras (for verification): ``t_end`` overrides the deck's end time, ``pulse=False``
    switches the pulse off, ``pulse_mode="userfunction"`` uses a load user function instead of
    phase restarts at the window edges.  ``n_samples`` > 1 adds "cm_samples": (n_samples, n, 3)
    CMs at n_samples equally spaced times 0 ... t_end; the solve is then also split at those
    times (each phase starts from the previous end state, as at the pulse edges).
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; known: {METHODS}")
    sc = pydriver.scene(deck_path)
    n = sc.n_bodies
    te = float(sc.t_end if t_end is None else t_end)
    out = {"method": method, "step": float(step), "cpu_s": float("nan"),
           "cm_end": np.full((n, 3), np.nan), "tip_end": np.full(3, np.nan),
           "reactions_end": np.full(12, np.nan), "n_steps": 0, "newton_iterations": 0,
           "jacobian_updates": 0, "rejected_steps": 0, "status": "ok"}
    try:
        model = _Model(sc, pulse=pulse, pulse_mode=pulse_mode)
        times = np.linspace(0.0, te, n_samples) if n_samples > 1 else ()
        cpu, n_steps, newton, jacobians, rejected = model.solve(float(step), te, times)
        cms, tip, reac = model.end_state(te)
        out.update(cpu_s=cpu, cm_end=cms, tip_end=tip, reactions_end=reac, n_steps=n_steps,
                   newton_iterations=newton, jacobian_updates=jacobians, rejected_steps=rejected)
        if n_samples > 1:
            out["cm_samples"] = np.array([model.samples[round(float(t), 12)] if t > 0 else model.samples[0.0]
                                          for t in times])
    except Exception as exc:  # noqa: BLE001 - report, do not abort a sweep
        out["status"] = f"{type(exc).__name__}: {exc}"
    return out


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("deck", nargs="?", default="inputs/uh60_part2_decay.nml")
    ap.add_argument("--step", type=float, default=1e-3)
    ap.add_argument("--method", default=METHODS[0])
    args = ap.parse_args()
    np.set_printoptions(precision=10, linewidth=120)
    res = simulate(args.deck, args.method, args.step)
    for key, val in res.items():
        print(f"{key}: {val}")
    sys.exit(0 if res["status"] == "ok" else 1)
