"""Exudyn peer for the forward-flight scene (inputs/uh60_part2_forward_flight.nml): the cable
between the hub clamp F and the blade cuff S2, the rotor turning at constant Omega, the blade
flapping, lagging and pitching, the cable in the 80 m/s stream.

rotorcable writes this scene in the hub frame (docs/model.md, "Rotor and hub frame"); Exudyn
has no moving reference frame for a kinematic tree, so the peer models it in the inertial
frame, which is the same physics (rotorcable's own ``frame = 'inertial'`` agrees with its hub
frame to 1e-8 m, tests/test_flight.py):

* **Chain tree** (``ObjectKinematicTree``, as in exudyn_route.py): link 0 is the rotor, a
  ``RevoluteZ`` joint at the rotor centre whose angle is prescribed to Omega t; the clamped
  body 1 is folded into it (its frame R_1 = R_0 Rz(gamma_1) Ry(beta_1) is the next link's joint
  transformation, P_2 the offset); every free Cardan joint with twist (``joint = 'xyz'``,
  R_rel = Rx(phi) Ry(theta) Rz(psi)) is three links ``RevoluteX`` (massless), ``RevoluteY``
  (massless), ``RevoluteZ`` (the body, CM at (0, 0, L/2)).  Tree coordinates after the rotor's
  are exactly rotorcable's q (checked at the start: CMs agree to round-off).  Joint springs and
  dampers are the tree's PD terms (P = c, D = d, offsets = rest), gravity the tree's.
* **Blade tree**: the blade's rigid motion as a second tree: rotor (``RevoluteZ`` at the rotor
  centre), flap, lead-lag, pitch, each a ``RevoluteZ`` whose joint transformation turns local z
  onto the deck's hinge axis, placed at the hinge points of the installed pose (all angles 0,
  rotor at 0): the product of exponentials T(t) = T_rotor T_flap T_lag T_pitch of
  docs/model.md, "Moving supports".  Its links carry a nominal mass (they are fully
  prescribed, so it only enters the multipliers).
* **Prescribed angles**: one ``CoordinateConstraint`` per prescribed coordinate (both rotors and
  the three hinges) between a ground coordinate and the tree coordinate, with an
  ``offsetUserFunction`` Omega t or the Fourier series in the blade azimuth psi_b = Omega t +
  psi_b0 (a0 + sum a_kc cos k psi_b + a_ks sin k psi_b, degrees in the deck), converted to
  Exudyn symbolic user functions (evaluated in C++, no Python call per residual) when
  ``exudyn.symbolic`` accepts them, Python functions otherwise.
* **Clamp B**: ``ObjectJointGeneric`` (6 axes) between the chain tip (0, 0, L_n) of the last
  link and a marker on the blade's pitch link at the installed clamp position, with
  ``rotationMarker1`` the installed clamp rotation in that link's frame.
* **Drag** (cross-flow, docs/model.md "Aerodynamic drag"): F_j = 1/2 rho C_d d_j L_j |u_n| u_n
  at each CM with u = V_inf - v_C, V_inf = (-V, 0, 0) constant in the inertial frame.  It
  enters through the chain tree's ``forceUserFunction`` (generalized forces
  Q_k = a_k . sum_{j >= k} (c_j - p_k) x F_j from a forward kinematic pass in numpy), the one
  Python call per residual that Exudyn cannot avoid for a state-dependent distributed load on
  a tree.  Exudyn differentiates it numerically for its Jacobian.

Start: rotorcable's consistent start (``pydriver.flight_start``-like: equilibrium of the
loads at t = 0 relative to the hub, made consistent with the moving clamp by the core); the
chain tree starts at those q, q_dot, the rotors at 0 with rate Omega, the hinges at their
angles and rates at psi_b0.  Solver: Exudyn's default generalized-alpha (index 3), fixed step h
(the accuracy knob), as in exudyn_route.py.  Outputs: CMs in the *hub* frame,
r_hub = c + Rz(-Omega t) (r - c), at equally spaced sample times (the solve is split there).
"""

from __future__ import annotations

import math
import time

import numpy as np

import exudyn as exu
from exudyn.itemInterface import (MarkerKinematicTreeRigid, MarkerNodeCoordinate, NodeGenericODE2,
                                  NodePointGround, ObjectConnectorCoordinate, ObjectGround,
                                  ObjectJointGeneric, ObjectKinematicTree, SensorKinematicTree)

from flight_scene import flight_model, flight_start  # noqa: F401  (re-exported for the scripts)

DEG = math.pi / 180.0
_OVT = exu.OutputVariableType


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _z_onto(u):
    """A rotation taking e_z onto the unit vector u (Rodrigues; a half turn about x for -e_z)."""
    u = np.asarray(u, float) / np.linalg.norm(u)
    c = float(u[2])
    if c < -1.0 + 1e-12:
        return _rx(math.pi)
    k = np.cross([0.0, 0.0, 1.0], u)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + kx + kx @ kx / (1.0 + c)


class FlightModel:
    """The assembled Exudyn system of a forward-flight model (see the module docstring)."""

    def __init__(self, model, q0, v0, symbolic: bool = True):
        deck, desc = model.deck, model.description
        if deck["chain.joint"] != "xyz":
            raise NotImplementedError("only joint = 'xyz' is modelled")
        b = desc["bodies"]
        if not b.locked[0] or np.any(b.locked[1:]):
            raise NotImplementedError("only a clamped first body")
        rot = desc["rotor"]
        if rot is None or rot["profile"] != "constant" or not rot["hub"]:
            raise NotImplementedError("a constant-speed rotor in the hub frame")
        self.omega = float(rot["speed"]["omega"])
        self.centre = np.asarray(rot["centre"], float)
        self.azimuth0 = float(rot["azimuth0"])
        n = self.n = model.n_bodies
        L = np.asarray(b.lengths, float)
        self.lengths = L
        masses = np.asarray(b.masses, float)
        radii = np.asarray(b.radii, float)
        ixx = masses * (L**2 + 3 * radii**2) / 12.0                                  # eq. 4.50
        SC = self.SC = exu.SystemContainer()
        mbs = self.mbs = SC.AddSystem()
        self._keep = []                        # symbolic user functions must outlive the solve

        # --- chain tree: rotor link, then (X, Y, Z) links per free joint --------------------
        R0 = np.asarray(desc["base_rotation"], float)
        g1, b1 = np.radians(deck["shape.gamma_deg"][0]), np.radians(deck["shape.beta_deg"][0])
        R1 = R0 @ _rz(g1) @ _ry(b1)
        P2 = R1 @ np.array([0.0, 0.0, L[0]])                 # P_1 = origin (clamp F)
        types = [exu.JointType.RevoluteZ]
        parents, rots, offs = [-1], [np.eye(3)], [[0.0, 0.0, 0.0]]
        inertias, coms, link_mass = [np.zeros((3, 3))], [[0.0, 0.0, 0.0]], [0.0]
        self.body_link = {}
        for j in range(1, n):
            for axis, jt in enumerate((exu.JointType.RevoluteX, exu.JointType.RevoluteY, exu.JointType.RevoluteZ)):
                types.append(jt)
                parents.append(len(types) - 2)
                if axis == 0:
                    rots.append(R1 if j == 1 else np.eye(3))
                    offs.append(list(P2 - self.centre) if j == 1 else [0.0, 0.0, L[j - 1]])
                else:
                    rots.append(np.eye(3))
                    offs.append([0.0, 0.0, 0.0])
                body = axis == 2
                inertias.append(np.diag([ixx[j], ixx[j], masses[j] * radii[j]**2 / 2.0]) if body else np.zeros((3, 3)))
                coms.append([0.0, 0.0, 0.5 * L[j]] if body else [0.0, 0.0, 0.0])
                link_mass.append(float(masses[j]) if body else 0.0)
            self.body_link[j] = len(types) - 1
        nt = len(types)
        if nt - 1 != model.nq:
            raise RuntimeError(f"tree has {nt - 1} joint coordinates, the model {model.nq}")
        stiff = np.concatenate([[0.0], desc["stiffness"]])
        damp = np.concatenate([[0.0], desc["damping"]])
        rest = np.concatenate([[0.0], desc["rest"]])
        self.tree_types, self.tree_parents = types, parents
        self.tree_rots, self.tree_offs = [np.asarray(r, float) for r in rots], np.asarray(offs, float)
        self.node = mbs.AddNode(NodeGenericODE2(
            referenceCoordinates=[0.0] * nt, initialCoordinates=[0.0] + list(q0),
            initialCoordinates_t=[self.omega] + list(v0), numberOfODE2Coordinates=nt))
        tree_args = dict(
            nodeNumber=self.node, jointTypes=types, linkParents=parents,
            jointTransformations=exu.Matrix3DList(rots), jointOffsets=exu.Vector3DList(offs),
            linkInertiasCOM=exu.Matrix3DList(inertias), linkCOMs=exu.Vector3DList(coms),
            linkMasses=link_mass, baseOffset=list(self.centre),
            gravity=list(np.asarray(deck["loads.gravity"], float)),
            jointPControlVector=list(stiff), jointPositionOffsetVector=list(rest),
            jointDControlVector=list(damp), jointVelocityOffsetVector=[0.0] * nt)
        self.drag = "drag" in deck.groups
        if self.drag:
            cd = np.broadcast_to(np.asarray(deck["drag.cd"], float), (n,))
            self.drag_k = 0.5 * deck["drag.air_density"] * cd * 2.0 * radii * L
            self.stream = np.asarray(deck["drag.stream_velocity"], float) - np.array([deck["drag.forward_speed"], 0, 0])
            tree_args["forceUserFunction"] = self._drag_forces
        self.tree = mbs.AddObject(ObjectKinematicTree(**tree_args))

        # --- blade tree: rotor, flap, lag, pitch ----------------------------------------------
        bl = deck.values["blade"]
        flap = np.asarray(bl["flap_hinge"], float)
        lag = np.asarray(bl["lag_hinge"], float) if deck.has("blade.lag_hinge") else flap
        pitch = np.asarray(bl["pitch_hinge"], float) if deck.has("blade.pitch_hinge") else flap
        if bl["motion"] != "fourier" or bl["lag_extra_deg"] != 0.0:
            raise NotImplementedError("Fourier blade motion without the extra lead-lag oscillation")
        points = [self.centre, flap, lag, pitch]
        axes = [np.array([0.0, 0.0, 1.0]), bl["flap_axis"], bl["lag_axis"], bl["pitch_axis"]]
        W = np.eye(3)
        brots, boffs = [], []
        for k, (p, u) in enumerate(zip(points, axes)):
            A = W.T @ _z_onto(u)                   # joint transformation in the parent link's frame
            brots.append(A)
            boffs.append([0.0, 0.0, 0.0] if k == 0 else list(W.T @ (p - points[k - 1])))
            W = W @ A
        self.coeffs = [np.asarray(bl[f"{h}_deg"], float) * DEG for h in ("flap", "lag", "pitch")]
        ang0 = [self._fourier(c, self.azimuth0) for c in self.coeffs]
        self.blade_node = mbs.AddNode(NodeGenericODE2(
            referenceCoordinates=[0.0] * 4, initialCoordinates=[0.0] + [a[0] for a in ang0],
            initialCoordinates_t=[self.omega] + [a[1] * self.omega for a in ang0], numberOfODE2Coordinates=4))
        nominal = 1e-3                              # kg, kg m^2: prescribed links, only in the multipliers
        self.blade = mbs.AddObject(ObjectKinematicTree(
            nodeNumber=self.blade_node, jointTypes=[exu.JointType.RevoluteZ] * 4, linkParents=[-1, 0, 1, 2],
            jointTransformations=exu.Matrix3DList(brots), jointOffsets=exu.Vector3DList(boffs),
            linkInertiasCOM=exu.Matrix3DList([np.eye(3) * nominal] * 4),
            linkCOMs=exu.Vector3DList([[0.0, 0.0, 0.0]] * 4), linkMasses=[nominal] * 4,
            baseOffset=list(self.centre), gravity=[0.0, 0.0, 0.0]))

        # --- prescribed coordinates -----------------------------------------------------------
        ground_node = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
        m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
        self.symbolic = symbolic
        self._prescribe(m_ground, self.node, 0, None)
        self._prescribe(m_ground, self.blade_node, 0, None)
        for k in range(3):
            self._prescribe(m_ground, self.blade_node, k + 1, self.coeffs[k])

        # --- clamp B ----------------------------------------------------------------------------
        clamp_p, clamp_R = desc["clamp"]
        m_tip = mbs.AddMarker(MarkerKinematicTreeRigid(objectNumber=self.tree, linkNumber=self.body_link[n - 1],
                                                       localPosition=[0.0, 0.0, float(L[n - 1])]))
        m_b = mbs.AddMarker(MarkerKinematicTreeRigid(objectNumber=self.blade, linkNumber=3,
                                                     localPosition=list(W.T @ (np.asarray(clamp_p) - points[3]))))
        self.joint = mbs.AddObject(ObjectJointGeneric(markerNumbers=[m_tip, m_b], constrainedAxes=[1] * 6,
                                                      rotationMarker1=W.T @ np.asarray(clamp_R, float)))
        self.s_cm = {j: mbs.AddSensor(SensorKinematicTree(
            objectNumber=self.tree, linkNumber=link, localPosition=[0.0, 0.0, 0.5 * float(L[j])],
            writeToFile=False, storeInternal=False, outputVariableType=_OVT.Position))
            for j, link in self.body_link.items()}
        self.cm1 = P2 * 0.5                         # clamped body 1 at t = 0 (rotates with the hub)
        mbs.Assemble()

    # ------------------------------------------------------------------------------------------
    @staticmethod
    def _fourier(c, psi):
        """Angle and its derivative d/dpsi of a0 + sum (a_kc cos k psi + a_ks sin k psi)."""
        a, da = c[0], 0.0
        for k in range(1, (len(c) - 1) // 2 + 1):
            ac, as_ = c[2 * k - 1], c[2 * k] if 2 * k < len(c) else 0.0
            a += ac * math.cos(k * psi) + as_ * math.sin(k * psi)
            da += k * (-ac * math.sin(k * psi) + as_ * math.cos(k * psi))
        return a, da

    def _prescribed_functions(self, coeffs, sym):
        """(position, velocity) user functions of one prescribed coordinate, written once for
        numpy/math and for exudyn.symbolic (same expressions)."""
        om, psi0 = self.omega, self.azimuth0
        sin, cos = (sym.sin, sym.cos) if sym is not None else (math.sin, math.cos)
        if coeffs is None:
            def pos(mbs, t, itemNumber, lOffset):
                return om * t

            def vel(mbs, t, itemNumber, lOffset):
                return om + 0.0 * t
            return pos, vel
        c = [float(x) for x in coeffs]
        harmonics = [(k, c[2 * k - 1], c[2 * k] if 2 * k < len(c) else 0.0) for k in range(1, (len(c) - 1) // 2 + 1)]

        def pos(mbs, t, itemNumber, lOffset):
            psi = om * t + psi0
            out = c[0] + 0.0 * t
            for k, ac, as_ in harmonics:
                out = out + ac * cos(k * psi) + as_ * sin(k * psi)
            return out

        def vel(mbs, t, itemNumber, lOffset):
            psi = om * t + psi0
            out = 0.0 * t
            for k, ac, as_ in harmonics:
                out = out + k * om * (-ac * sin(k * psi) + as_ * cos(k * psi))
            return out
        return pos, vel

    def _prescribe(self, m_ground, node, coordinate, coeffs):
        mbs = self.mbs
        m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=coordinate))
        pos, vel = self._prescribed_functions(coeffs, None)
        # CoordinateConstraint: q_m1 - q_m0 = offset(t), marker 0 the ground (value 0).
        c = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[m_ground, m], offsetUserFunction=pos,
                                                    offsetUserFunction_t=vel))
        if self.symbolic:
            try:
                from exudyn.utilities import CreateSymbolicUserFunction
                sym = exu.symbolic
                spos, svel = self._prescribed_functions(coeffs, sym)
                for fn, name in ((spos, "offsetUserFunction"), (svel, "offsetUserFunction_t")):
                    f = CreateSymbolicUserFunction(mbs, fn, name, itemIndex=c)
                    f.TransferUserFunction2Item(mbs, c, name)
                    self._keep.append(f)
            except Exception as exc:  # noqa: BLE001 - fall back to the Python function, say so
                self.symbolic = False
                self.symbolic_error = f"{type(exc).__name__}: {exc}"
        return c

    # ------------------------------------------------------------------------------------------
    def _kinematics(self, q, qd):
        """World frames, joint points/axes, CMs and CM velocities of the chain tree at (q, q_dot)."""
        nt = len(self.tree_types)
        R = np.empty((nt, 3, 3))
        p = np.empty((nt, 3))
        w = np.empty((nt, 3))
        v = np.empty((nt, 3))
        axis = np.empty((nt, 3))
        unit = {exu.JointType.RevoluteX: 0, exu.JointType.RevoluteY: 1, exu.JointType.RevoluteZ: 2}
        for i in range(nt):
            par = self.tree_parents[i]
            Rp = np.eye(3) if par < 0 else R[i - 1]
            pp = self.centre if par < 0 else p[i - 1]
            wp = np.zeros(3) if par < 0 else w[i - 1]
            vp = np.zeros(3) if par < 0 else v[i - 1]
            off = Rp @ self.tree_offs[i]
            A = Rp @ self.tree_rots[i]
            k = unit[self.tree_types[i]]
            a = A[:, k]
            c, s = math.cos(q[i]), math.sin(q[i])
            if k == 0:
                Rj = _rx_cs(c, s)
            elif k == 1:
                Rj = _ry_cs(c, s)
            else:
                Rj = _rz_cs(c, s)
            R[i] = A @ Rj
            p[i] = pp + off
            v[i] = vp + np.cross(wp, off)
            w[i] = wp + a * qd[i]
            axis[i] = a
        return R, p, w, v, axis

    def _drag_forces(self, mbs, t, itemNumber, q, q_t):
        q = np.asarray(q)
        qd = np.asarray(q_t)
        R, p, w, v, axis = self._kinematics(q, qd)
        nt = len(q)
        F = np.zeros((nt, 3))
        C = np.zeros((nt, 3))
        for j, link in self.body_link.items():
            e = R[link][:, 2]
            r = 0.5 * self.lengths[j] * e
            c = p[link] + r
            vc = v[link] + np.cross(w[link], r)
            u = self.stream - vc
            un = u - (u @ e) * e
            F[link] = self.drag_k[j] * math.sqrt(un @ un) * un
            C[link] = c
        # Q_k = a_k . sum_{j >= k} (c_j - p_k) x F_j  (serial chain: sums from the tip)
        SF = np.cumsum(F[::-1], axis=0)[::-1]
        SM = np.cumsum(np.cross(C, F)[::-1], axis=0)[::-1]
        Q = np.einsum("ij,ij->i", axis, SM - np.cross(p, SF))
        return list(Q)

    # ------------------------------------------------------------------------------------------
    def settings(self):
        s = exu.SimulationSettings()
        s.solution.file.write = False
        s.solution.sensors.active = False
        s.solution.restart.write = False
        s.timeIntegration.verboseMode = 0
        s.timeIntegration.verboseModeFile = 0
        s.show.statistics = False
        s.show.computationTime = False
        s.show.globalTimers = False
        return s

    def cms_hub(self, t):
        """CMs now, in the hub frame (clamped body 1 included)."""
        Rt = _rz(-self.omega * t)
        out = np.zeros((self.n, 3))
        out[0] = self.cm1
        for j, s in self.s_cm.items():
            out[j] = self.centre + Rt @ (np.asarray(self.mbs.GetSensorValues(s)) - self.centre)
        return out

    def solve(self, step: float, t_end: float, sample_times) -> dict:
        """Integrate 0 -> t_end with step h, split at the sample times; CMs (hub frame) there."""
        times = sorted(set(round(float(t), 12) for t in sample_times if 0.0 < t <= t_end) | {round(t_end, 12)})
        samples = {0.0: self.cms_hub(0.0)}
        s = self.settings()
        cpu = 0.0
        n_steps = newton = jac = rejected = 0
        a = 0.0
        for b in times:
            m = round((b - a) / step)
            if m < 1 or abs(m * step - (b - a)) > 1e-9 * max(1.0, b - a):
                raise ValueError(f"step {step} does not divide [{a}, {b}]")
            s.timeIntegration.startTime = a
            s.timeIntegration.endTime = b
            s.timeIntegration.numberOfSteps = m
            c0 = time.process_time()
            exu.SolveDynamic(self.mbs, s, updateInitialValues=True, autoAssemble=False)
            cpu += time.process_time() - c0
            it = self.mbs.sys["dynamicSolver"].it
            n_steps += int(it.currentStepIndex) - 1
            newton += int(it.newtonStepsCount)
            jac += int(it.newtonJacobiCount)
            rejected += int(it.rejectedModifiedNewtonSteps)
            samples[b] = self.cms_hub(b)
            a = b
        return {"cpu_s": cpu, "n_steps": n_steps, "newton_iterations": newton, "jacobian_updates": jac,
                "rejected_steps": rejected, "samples": samples}


def _rx_cs(c, s):
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry_cs(c, s):
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz_cs(c, s):
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def simulate(model, q0, v0, step: float, t_end: float, n_samples: int, symbolic: bool = True) -> dict:
    """One Exudyn run of a flight model from (q0, v0): CMs in the hub frame at n_samples equally
    spaced times 0 ... t_end ("cm_samples", (n_samples, n, 3)), CPU time of the solve alone,
    Exudyn's counters, "status" ("ok" or the error)."""
    out = {"status": "ok", "step": float(step)}
    try:
        fm = FlightModel(model, q0, v0, symbolic=symbolic)
        times = np.linspace(0.0, t_end, n_samples)
        r = fm.solve(float(step), float(t_end), times[1:])
        out.update({k: v for k, v in r.items() if k != "samples"})
        out["cm_samples"] = np.array([r["samples"][round(float(t), 12)] for t in times])
        out["cm_end"] = out["cm_samples"][-1]
        out["symbolic"] = fm.symbolic
        if out["n_steps"] <= 0 or not np.all(np.isfinite(out["cm_samples"])):
            out["status"] = f"no work done: {out['n_steps']} steps"
    except Exception as exc:  # noqa: BLE001 - a failing peer run is a data point
        out["status"] = f"{type(exc).__name__}: {exc}"
    return out
