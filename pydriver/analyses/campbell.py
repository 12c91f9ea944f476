"""Campbell diagram (issue 13): natural frequencies against rotor speed, with the rotor
harmonics, and every crossing inside the operating range.

At each speed of the grid 0 ... rpm_max the equilibrium is found with the full rotating-frame
terms (continuation from the previous speed), and the equations are linearised about it on the
constraint manifold (``CoreModel.modal_matrices``): M_r, K_r (centrifugal stiffening included)
and D_r (joint dampers and the gyroscopic Coriolis coupling, which splits modes with speed).
The eigenvalues of the first-order pencil, s = -zeta w +- i w sqrt(1 - zeta^2), give frequency
and damping; modes are followed from speed to speed by the mass-weighted modal assurance
criterion (MAC) of their complex shapes.  numpy's eig on the state matrix is used: at the
sizes of a cable model (tens of coordinates) it is exact enough and leaves the core small.
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.common import base_summary
from pydriver.result import Result


def speed_key(model) -> str:
    """The deck key that sets the rotor speed (the newer &rotor or the older &loads)."""
    return "rotor.rpm" if "rotor" in model.deck.groups else "loads.rotor_rpm"


def complex_modes(mats: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eigenvalues s and shapes in q of the linearised system: one of each oscillating pair
    (Im s > 0) by ascending frequency, then the non-oscillating ones (real s: overdamped, or,
    with Re s > 0, a divergent equilibrium).  Also returns which are oscillating."""
    m, k, d, basis = mats["M_r"], mats["K_r"], mats["D_r"], mats["basis"]
    nf = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-minv @ k, -minv @ d]])
    s, v = np.linalg.eig(a)
    tiny = 1e-9 * max(1.0, np.max(np.abs(s)))
    osc = s.imag > tiny
    real = np.abs(s.imag) <= tiny
    order = np.concatenate([np.flatnonzero(osc)[np.argsort(s.imag[osc])], np.flatnonzero(real)])
    return s[order], basis @ v[:nf, order], osc[order]


def mac(a: np.ndarray, b: np.ndarray, m_full: np.ndarray) -> np.ndarray:
    """Mass-weighted MAC between the columns of a and b (complex shapes in q)."""
    cross = a.conj().T @ m_full @ b
    na = np.real(np.einsum("ij,ik,kj->j", a.conj(), m_full, a))
    nb = np.real(np.einsum("ij,ik,kj->j", b.conj(), m_full, b))
    return np.abs(cross) ** 2 / np.outer(na, nb)


def degenerate_clusters(sv: np.ndarray, count: int, rel: float = 1e-7) -> list[np.ndarray]:
    """Groups (two or more) among the first ``count`` eigenvalues that coincide to ``rel``:
    a degenerate mode pair such as the flap and lag modes of an isotropic cable at rest."""
    out, i = [], 0
    while i < count:
        j = i + 1
        while j < len(sv) and abs(sv[j] - sv[i]) <= rel * max(abs(sv[i]), 1e-300):
            j += 1
        if j - i > 1:
            out.append(np.arange(i, j))
        i = j
    return out


def resolve_degenerate(shapes: np.ndarray, sv: np.ndarray, count: int, next_shapes: np.ndarray,
                       next_sv: np.ndarray, m_full: np.ndarray) -> np.ndarray:
    """Shapes with every degenerate cluster's basis replaced by the one the next speed picks.

    Within a degenerate eigenspace any basis is an eigenbasis, and LAPACK returns one set by
    round-off: the flap/lag pair of an isotropic cable at rest comes out in a different mix
    on another CPU, and MAC tracking then labels the modes at random.  The speed next on the
    grid splits the cluster; its modes that lie most in the cluster's space, projected onto it
    (mass-orthogonally) and ordered by their own frequency, are the basis that tracking can
    follow.  Projection: P w = V (V^H M V)^-1 V^H M w."""
    out = shapes.copy()
    for idx in degenerate_clusters(sv, count):
        v = shapes[:, idx]
        gram = v.conj().T @ m_full @ v
        coeff = np.linalg.solve(gram, v.conj().T @ m_full @ next_shapes)
        proj = v @ coeff
        # Fraction of each next-speed shape inside the cluster's space (1 = entirely).
        inside = (np.real(np.einsum("ij,ik,kj->j", proj.conj(), m_full, proj))
                  / np.real(np.einsum("ij,ik,kj->j", next_shapes.conj(), m_full, next_shapes)))
        chosen = np.sort(np.argsort(-inside)[:len(idx)])            # next_sv is ascending
        out[:, idx] = proj[:, chosen]
    return out


def crossings(rpm, freqs, harmonics: int, op_range) -> list[dict]:
    """Where a tracked mode's frequency meets k/rev inside the operating range (linear
    interpolation between grid speeds).  Only between speeds where the mode oscillates at
    both ends: an overdamped mode (frequency 0) cannot resonate, and interpolating into its 0
    would invent a crossing."""
    out = []
    for mode in range(freqs.shape[1]):
        for k in range(1, harmonics + 1):
            gap = freqs[:, mode] - k * rpm / 60.0
            for i in range(len(rpm) - 1):
                if freqs[i, mode] <= 0.0 or freqs[i + 1, mode] <= 0.0:
                    continue
                if gap[i] == 0.0 or gap[i] * gap[i + 1] < 0.0:
                    w = gap[i] / (gap[i] - gap[i + 1]) if gap[i] != gap[i + 1] else 0.0
                    r = rpm[i] + w * (rpm[i + 1] - rpm[i])
                    if op_range[0] <= r <= op_range[1]:
                        out.append({"mode": mode + 1, "harmonic": k, "rpm": float(r),
                                    "frequency_hz": float(k * r / 60.0)})
    return sorted(out, key=lambda c: c["rpm"])


def campbell_analysis(model) -> Result:
    """Frequencies of the tracked modes over the speed grid, and the crossings."""
    t_wall = time.perf_counter()
    c = model.deck.values["campbell"]
    rpm_max = c["rpm_max"] if c["rpm_max"] is not None else model.description["rotor"]["omega_max"] * 30 / np.pi
    rpm = np.linspace(0.0, rpm_max, int(c["n_speeds"]))
    op = c["operating_rpm"] if c["operating_rpm"] is not None else [0.0, rpm_max]
    n_modes = int(c["n_modes"])
    s = model.deck.values["solver"]
    key = speed_key(model)
    freqs = np.zeros((len(rpm), n_modes))
    zetas = np.zeros((len(rpm), n_modes))
    macs = np.ones((len(rpm), n_modes))
    q_prev, tracked, unstable = None, None, []
    solved = []
    for r in rpm:
        m = model.with_changes({key: float(r), "case.analysis": "static"})
        q, lam, _ = m.core.static(m.q0 if q_prev is None else q_prev, 0.0, s["newton_tol"], s["newton_max_iter"])
        q_prev = q
        mats = m.core.modal_matrices(q, lam)
        solved.append((mats, *complex_modes(mats)))
    for i, r in enumerate(rpm):
        mats, sv, shapes, oscillating = solved[i]
        if i + 1 < len(rpm):
            shapes = resolve_degenerate(shapes, sv, n_modes, solved[i + 1][2], solved[i + 1][1], mats["M"])
        if tracked is None:
            if np.count_nonzero(oscillating) < n_modes:
                model.deck.fail("campbell", "n_modes", f"only {np.count_nonzero(oscillating)} oscillating modes "
                                                       f"at {r:.0f} rpm")
            pick = np.arange(n_modes)
        else:
            # Follow each tracked mode to the candidate it resembles most (greedy on the MAC).
            cm = mac(tracked, shapes, mats["M"])
            pick = np.full(n_modes, -1)
            for flat in np.argsort(-cm, axis=None):
                a, b = np.unravel_index(flat, cm.shape)
                if pick[a] < 0 and b not in pick:
                    pick[a] = b
                    macs[i, a] = cm[a, b]
        tracked = shapes[:, pick]
        freqs[i] = np.maximum(sv[pick].imag, 0.0) / (2.0 * np.pi)
        zetas[i] = -sv[pick].real / np.abs(sv[pick])
        if np.any(sv.real > 1e-9 * np.max(np.abs(sv))):
            unstable.append(float(r))
    found = crossings(rpm, freqs, int(c["harmonics"]), op)
    in_op = (rpm >= op[0]) & (rpm <= op[1])
    summary = base_summary(model, "campbell", time.perf_counter() - t_wall)
    oscillating = freqs[in_op] > 0.0
    lowest = float(np.min(freqs[in_op][oscillating])) if np.any(oscillating) else 0.0
    summary.update(rpm=[float(x) for x in rpm], operating_rpm=[float(x) for x in op],
                   harmonics=int(c["harmonics"]), lag_band_hz=[float(x) for x in c["lag_band_hz"]],
                   frequencies_hz=[[float(x) for x in row] for row in freqs],
                   crossings=found, lowest_frequency_hz=lowest,
                   highest_1rev_hz=float(op[1] / 60.0),
                   below_1rev_in_operating_range=bool(lowest < op[1] / 60.0),
                   min_mac=float(np.min(macs)), unstable_rpm=unstable)
    summary["warnings"] = []
    for mode in np.flatnonzero(np.any(freqs <= 0.0, axis=0)):
        at = rpm[freqs[:, mode] <= 0.0]
        summary["warnings"].append(f"mode {mode + 1} does not oscillate (overdamped, zeta >= 1) at {len(at)} "
                                   f"speeds from {at.min():.0f} rpm: drawn at 0 Hz, no crossings counted there")
    if unstable:
        summary["warnings"] += [f"the equilibrium is unstable (an eigenvalue with positive real part) at "
                               f"{len(unstable)} speeds from {min(unstable):.0f} rpm: divergence or flutter"]
    table = {"rpm": np.repeat(rpm, n_modes), "mode": np.tile(np.arange(1, n_modes + 1), len(rpm)),
             "f_hz": freqs.reshape(-1), "zeta": zetas.reshape(-1), "mac": macs.reshape(-1)}
    cross_table = {k: np.array([x[k] for x in found], float) for k in ("mode", "harmonic", "rpm", "frequency_hz")}
    extra = {"tables": {"campbell.csv": table}, "campbell": {"rpm": rpm, "f": freqs, "zeta": zetas}}
    if found:
        extra["tables"]["campbell_crossings.csv"] = cross_table
    return Result(summary=summary, extra=extra)
