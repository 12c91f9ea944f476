"""Campbell diagram (issue 13): natural frequencies against rotor speed, with the rotor
harmonics, and every crossing inside the operating range.

At each speed of the grid 0 ... rpm_max the equilibrium is found with the full rotating-frame
terms (continuation from the previous speed), and the equations are linearised about it on the
constraint manifold (``CoreModel.modal_matrices``): M_r, K_r (centrifugal stiffening included)
and D_r (joint dampers and the gyroscopic Coriolis coupling, which splits modes with speed).
The eigenvalues of the first-order system, s = -zeta w +- i w sqrt(1 - zeta^2), give frequency
and damping (``linear_modes.complex_modes``, the damped modes of the modal analysis too); modes
are followed from speed to speed by the mass-weighted modal assurance criterion (MAC) of their
complex shapes.

The diagram is that of the steady loads: a force pulse of the deck (``&loads pulse_body``) is a
dynamic excitation and is left out, as in the static and modal analyses.
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.common import base_summary
from pydriver.analyses.hover_modes import hover_changes
from pydriver.analyses.linear_modes import complex_modes, mac
from pydriver.analyses.resonance import excited_harmonics, harmonic_orders
from pydriver.analyses.statics import unforced, unforced_note
from pydriver.errors import RunError
from pydriver.motions import RPM
from pydriver.run_result import Result
from pydriver.richardson import departing_level, level_text, outside_physical_range, richardson, richardson_two
from pydriver.schema import lookup

#: Below this MAC between neighbouring speeds the tracking may have swapped modes.  0.9 is the
#: customary threshold of "the same mode" in MAC correlation (Allemang, "The modal assurance
#: criterion - twenty years of use and abuse", Sound and Vibration 37(8), 2003) and the value
#: the reference deck is tested against (tests/test_campbell.py: 0.957 at 26 speeds).
MAC_THRESHOLD = 0.9

#: A single ``operating_rpm`` value v is one operating speed; crossings are reported within
#: v (1 +- this): a governed rotor holds its speed to a few percent (droop, transients).
SINGLE_SPEED_MARGIN = 0.05


# -- deck values ------------------------------------------------------------------------------

def diagram_top(model) -> float:
    """``rpm_max``, or the deck's rotor speed when not given [rpm]; it must be above 0."""
    c = model.deck.values["campbell"]
    if c["rpm_max"] is not None:
        return float(c["rpm_max"])
    top = float(model.description["rotor"]["omega_max"] * 30.0 / np.pi)
    if not top > 0.0:
        model.deck.fail("campbell", "rpm_max", "is not given and the rotor speed is 0: the diagram needs a "
                                               "highest speed above 0")
    return top


def operating_range(model, rpm_max: float) -> tuple[tuple[float, float], list[str]]:
    """The speed range [rpm] in which crossings are reported, and the warnings it needs.

    Two values are the range; given high to low they are sorted (with a warning: the order
    carries no meaning, and the old code then reported no crossings at all).  One value v is
    one operating speed: the range v (1 +- SINGLE_SPEED_MARGIN), cut at 0 and rpm_max.  No
    value: 0 ... rpm_max.  More than two values, or a speed above rpm_max (where the diagram
    has no data, so crossings there would silently be missing), are a DeckError.
    """
    given = model.deck["campbell.operating_rpm"]
    if given is None:
        return (0.0, rpm_max), []
    values = [float(x) for x in given]
    if len(values) not in (1, 2):
        model.deck.fail("campbell", "operating_rpm", f"takes one operating speed or a range (min, max) [rpm], "
                                                     f"got {len(values)} values")
    if max(values) > rpm_max * (1.0 + 1e-12):
        model.deck.fail("campbell", "operating_rpm", f"reaches {max(values):g} rpm, above the diagram's "
                                                     f"rpm_max = {rpm_max:g} rpm: raise rpm_max or lower the range")
    if len(values) == 1:
        v = values[0]
        return (v * (1.0 - SINGLE_SPEED_MARGIN), min(v * (1.0 + SINGLE_SPEED_MARGIN), rpm_max)), []
    warnings = []
    if values[0] > values[1]:
        warnings.append(f"&campbell operating_rpm = {values[0]:g}, {values[1]:g} is given high to low: taken as "
                        f"the range {values[1]:g} ... {values[0]:g} rpm")
    return (min(values), max(values)), warnings


def lag_band(model) -> tuple[tuple[float, float], list[str]]:
    """The lead-lag band [Hz] drawn in the diagram: exactly two values, sorted (with a warning
    when given high to low); another count is a DeckError."""
    values = [float(x) for x in model.deck["campbell.lag_band_hz"]]
    if len(values) != 2:
        model.deck.fail("campbell", "lag_band_hz", f"takes two values (low, high) [Hz], got {len(values)}")
    warnings = []
    if values[0] > values[1]:
        warnings.append(f"&campbell lag_band_hz = {values[0]:g}, {values[1]:g} is given high to low: drawn as "
                        f"{values[1]:g} ... {values[0]:g} Hz")
    return (min(values), max(values)), warnings


def check_mode_count(model, n_modes: int) -> None:
    """n_modes can be at most the model's number of modes, coordinates minus constraints."""
    nf = model.nq - model.nc
    if n_modes > nf:
        model.deck.fail("campbell", "n_modes", f"is {n_modes}, but the model has {nf} modes ({model.nq} "
                                               f"coordinates, {model.nc} constraints)")


# -- modes at one speed -----------------------------------------------------------------------

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
    follow.  Projection: P w = V (V^H M V)^+ V^H M w (the pseudo-inverse: a defective cluster's
    shapes need not be independent)."""
    out = shapes.copy()
    for idx in degenerate_clusters(sv, count):
        v = shapes[:, idx]
        gram = v.conj().T @ m_full @ v
        coeff = np.linalg.pinv(gram, rcond=1e-10, hermitian=True) @ (v.conj().T @ m_full @ next_shapes)
        proj = v @ coeff
        # Fraction of each next-speed shape inside the cluster's space (1 = entirely).
        inside = (np.real(np.einsum("ij,ik,kj->j", proj.conj(), m_full, proj))
                  / np.real(np.einsum("ij,ik,kj->j", next_shapes.conj(), m_full, next_shapes)))
        # Shapes entirely inside (to round-off) tie; the lowest of them come first then.
        rank = np.lexsort((np.arange(len(inside)), -np.where(inside >= 1.0 - 1e-6, 1.0, inside)))
        chosen = np.sort(rank[:len(idx)])                           # next_sv is ascending
        out[:, idx] = proj[:, chosen]
    return out


# -- the diagram ------------------------------------------------------------------------------

def shapes_speed(rpm: np.ndarray, op, operating_rpm) -> int:
    """The index of the grid speed whose mode shapes a run keeps (``--vtk``): the one nearest the
    operating speed, a single &campbell operating_rpm, else the top of the operating range."""
    target = float(operating_rpm[0]) if operating_rpm is not None and len(operating_rpm) == 1 else float(op[1])
    return int(np.argmin(np.abs(np.asarray(rpm, float) - target)))


def crossings(rpm, freqs, harmonics, op_range) -> list[dict]:
    """Where a tracked mode's (damped) frequency meets k/rev inside the operating range (linear
    interpolation between grid speeds), k over ``harmonics`` (K: 1 ... K, or the excited orders,
    :func:`pydriver.analyses.resonance.excited_harmonics`).  Only between speeds where the mode
    oscillates at both ends: an overdamped mode (frequency 0) cannot resonate, and interpolating
    into its 0 would invent a crossing."""
    rpm = np.asarray(rpm, float)
    out = []
    for mode in range(freqs.shape[1]):
        f = freqs[:, mode]
        both = (f[:-1] > 0.0) & (f[1:] > 0.0)
        for k in (int(x) for x in harmonic_orders(harmonics)):
            gap = f - k * rpm / 60.0
            for i in np.flatnonzero(both & ((gap[:-1] == 0.0) | (gap[:-1] * gap[1:] < 0.0))):
                w = gap[i] / (gap[i] - gap[i + 1]) if gap[i] != gap[i + 1] else 0.0
                r = rpm[i] + w * (rpm[i + 1] - rpm[i])
                if op_range[0] <= r <= op_range[1]:
                    out.append({"mode": mode + 1, "harmonic": k, "rpm": float(r),
                                "frequency_hz": float(k * r / 60.0)})
    return sorted(out, key=lambda c: c["rpm"])


def tracking_macs(macs: np.ndarray, zero: np.ndarray) -> np.ndarray:
    """The MAC of each step that tests the tracking: a step from a zero-stiffness mode is left
    out (set to 1).  Such a mode has no shape of its own (any basis of the null space is an
    eigenbasis; the next speed's modes projected into it stand in), and a cable without springs
    moves its equilibrium between 0 rpm and the first speed, so that step's MAC is low on any
    grid."""
    out = macs.copy()
    out[1:][zero[:-1]] = 1.0
    return out


def lowest_in_range(rpm: np.ndarray, freqs: np.ndarray, op) -> float:
    """The lowest oscillating frequency over the operating range [Hz] (0 if none oscillates):
    at the grid speeds inside it and at its two ends, interpolated linearly where the mode
    oscillates at both neighbouring speeds (as for crossings).  The ends matter for a narrow
    range, one operating speed's band, which may hold no grid speed at all."""
    values = [freqs[(rpm >= op[0]) & (rpm <= op[1])].ravel()]
    for end in op:
        i = int(np.clip(np.searchsorted(rpm, end) - 1, 0, len(rpm) - 2))
        w = (end - rpm[i]) / (rpm[i + 1] - rpm[i])
        both = (freqs[i] > 0.0) & (freqs[i + 1] > 0.0)
        values.append(((1.0 - w) * freqs[i] + w * freqs[i + 1])[both])
    found = np.concatenate(values)
    found = found[found > 0.0]
    return float(np.min(found)) if found.size else 0.0


def mac_warning(rpm: np.ndarray, macs: np.ndarray) -> list[str]:
    """The warning for modes followed across a MAC below MAC_THRESHOLD: each such mode's worst
    step, and the n_speeds that would halve the step (capped at the schema's bound)."""
    low = [m for m in range(macs.shape[1]) if np.min(macs[:, m]) < MAC_THRESHOLD]
    if not low:
        return []
    steps = []
    for m in low:
        i = int(np.argmin(macs[:, m]))
        steps.append(f"mode {m + 1} from {rpm[i - 1]:.0f} to {rpm[i]:.0f} rpm (MAC {macs[i, m]:.2f})")
    limit = int(lookup("campbell", "n_speeds").high)
    finer = min(2 * len(rpm) - 1, limit)
    advice = (f"n_speeds = {finer} halves the speed step" if finer > len(rpm) else
              f"n_speeds is at its limit {limit}: the shapes change this fast between speeds (veering)")
    return [f"modes were followed across speeds whose shapes differ (MAC < {MAC_THRESHOLD}): "
            f"{'; '.join(steps)}: the tracking may have swapped modes there; {advice}"]


def non_oscillating_warnings(rpm: np.ndarray, freqs: np.ndarray, zero: np.ndarray) -> list[str]:
    """One warning per mode drawn at 0 Hz somewhere: zero stiffness, or overdamped."""
    out = []
    for mode in range(freqs.shape[1]):
        rigid = zero[:, mode]
        over = (freqs[:, mode] <= 0.0) & ~rigid
        if np.any(rigid):
            out.append(f"mode {mode + 1} has zero stiffness (no spring and no gravity or centrifugal load across "
                       f"a coordinate) at {np.count_nonzero(rigid)} speeds from {rpm[rigid].min():.0f} rpm: "
                       "drawn at 0 Hz, no crossings counted there")
        if np.any(over):
            out.append(f"mode {mode + 1} does not oscillate (overdamped, zeta >= 1) at {np.count_nonzero(over)} "
                       f"speeds from {rpm[over].min():.0f} rpm: drawn at 0 Hz, no crossings counted there")
    return out


def solve_speeds(model, rpm: np.ndarray) -> list[tuple]:
    """Equilibrium and modes at every speed (continuation: each speed starts from the last).

    One model, its rotor speed changed in place from speed to speed (``CoreModel.updated``,
    issue 23) and its force pulse off (:func:`unforced`); both are restored on return.  Building
    a model per speed from the deck (the earlier way) gave the same numbers (tests/
    test_model_update.py) and checked and assembled the deck at every speed.
    """
    s = model.deck.values["solver"]
    q_prev, solved = None, []
    with unforced(model), model.core.updated({"rotor.omega": model.core.parameter("rotor.omega")}):
        for r in rpm:
            model.core.update("rotor.omega", float(r) * RPM)
            q, lam, _ = model.core.static(model.q0 if q_prev is None else q_prev, 0.0, s["newton_tol"],
                                          s["newton_max_iter"])
            q_prev = q
            mats = model.core.modal_matrices(q, lam)
            mats["q"] = q                   # the equilibrium they are about (the shapes' --vtk frames)
            try:
                solved.append((mats, *complex_modes(mats)))
            except np.linalg.LinAlgError as err:
                raise RunError(f"deck '{model.name}': Campbell diagram at {r:.6g} rpm: the linearised equations "
                               f"cannot be solved for their modes ({err}: the reduced mass matrix is singular)"
                               ) from err
    return solved


def campbell_analysis(model, run_dir=None) -> Result:
    """Frequencies of the tracked modes over the speed grid, and the crossings (``run_dir``:
    unused, the registry's signature)."""
    t_wall = time.perf_counter()
    notes = unforced_note(model)
    # A flight scene's diagram is of its hover state, the state its resonance margins are judged
    # about (issue 36: the forward-flight cable's diagram had been of the blade in its installed
    # pose without drag, 267.4 rpm at 4/rev where its hover state meets 4/rev at 243 rpm).
    changes = hover_changes(model.deck)
    if changes:
        model = model.with_changes(changes)
        notes.append("the diagram is of the deck's hover state (" + ", ".join(
            f"&{k.split('.')[0]} {k.split('.')[1]} = {v}" for k, v in changes.items()) + "): the blade at its mean "
            "angles in still air, the state a flight's resonance margins are judged about")
    c = model.deck.values["campbell"]
    n_modes = int(c["n_modes"])
    check_mode_count(model, n_modes)
    rpm_max = diagram_top(model)
    op, op_warnings = operating_range(model, rpm_max)
    band, band_warnings = lag_band(model)
    rpm = np.linspace(0.0, rpm_max, int(c["n_speeds"]))
    freqs = np.zeros((len(rpm), n_modes))
    zetas = np.zeros((len(rpm), n_modes))
    macs = np.ones((len(rpm), n_modes))
    zero = np.zeros((len(rpm), n_modes), bool)
    tracked, unstable = None, []
    solved = solve_speeds(model, rpm)
    shown = shapes_speed(rpm, op, c["operating_rpm"])
    mode_shapes = None
    for i, r in enumerate(rpm):
        mats, sv, shapes, oscillating, zero_stiffness = solved[i]
        if i + 1 < len(rpm):
            shapes = resolve_degenerate(shapes, sv, n_modes, solved[i + 1][2], solved[i + 1][1], mats["M"])
        if tracked is None:
            available = np.count_nonzero(oscillating | zero_stiffness)
            if available < n_modes:
                model.deck.fail("campbell", "n_modes", f"only {available} modes oscillate at {r:.0f} rpm (the "
                                                       "others are overdamped): lower n_modes")
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
            if np.any(pick < 0):
                raise RunError(f"deck '{model.name}': Campbell diagram at {r:.6g} rpm: fewer modes than "
                               f"n_modes = {n_modes} to follow")
        tracked = shapes[:, pick]
        freqs[i] = np.maximum(sv[pick].imag, 0.0) / (2.0 * np.pi)
        if i == shown and "q" in mats:
            mode_shapes = {"rpm": float(r), "q": mats["q"], "shapes": tracked, "f_hz": freqs[i].copy()}
        size = np.abs(sv[pick])
        # A zero-stiffness mode (s = 0) has no damping ratio; 0 as in the modal analysis.
        zetas[i] = np.where(size > 0.0, -sv[pick].real / np.where(size > 0.0, size, 1.0), 0.0)
        zero[i] = zero_stiffness[pick]
        if np.any(sv.real > 1e-9 * np.max(np.abs(sv))):
            unstable.append(float(r))
    # The crossings that matter: with the harmonics that excite the cable (&resonance excitation).
    excited = excited_harmonics(model.deck, int(c["harmonics"]))
    found = crossings(rpm, freqs, excited, op)
    checked_macs = tracking_macs(macs, zero)
    summary = base_summary(model, "campbell", time.perf_counter() - t_wall)
    lowest = lowest_in_range(rpm, freqs, op)
    summary.update(rpm=[float(x) for x in rpm], operating_rpm=[float(x) for x in op],
                   harmonics=int(c["harmonics"]), excited_harmonics=excited, lag_band_hz=[float(x) for x in band],
                   frequencies_hz=[[float(x) for x in row] for row in freqs],
                   crossings=found, lowest_frequency_hz=lowest,
                   highest_1rev_hz=float(op[1] / 60.0),
                   below_1rev_in_operating_range=bool(lowest < op[1] / 60.0),
                   min_mac=float(np.min(checked_macs)), mac_threshold=MAC_THRESHOLD, unstable_rpm=unstable)
    if c["operating_rpm"] is not None and len(c["operating_rpm"]) == 1:
        summary["operating_speed_rpm"] = float(c["operating_rpm"][0])
    summary["warnings"] = (notes + op_warnings + band_warnings + non_oscillating_warnings(rpm, freqs, zero)
                           + mac_warning(rpm, checked_macs))
    if unstable:
        summary["warnings"] += [f"the equilibrium is unstable (an eigenvalue with positive real part) at "
                               f"{len(unstable)} speeds from {min(unstable):.0f} rpm: divergence or flutter"]
    table = {"rpm": np.repeat(rpm, n_modes), "mode": np.tile(np.arange(1, n_modes + 1), len(rpm)),
             "f_hz": freqs.reshape(-1), "zeta": zetas.reshape(-1), "mac": macs.reshape(-1)}
    cross_table = {k: np.array([x[k] for x in found], float) for k in ("mode", "harmonic", "rpm", "frequency_hz")}
    extra = {"tables": {"campbell.csv": table}, "campbell": {"rpm": rpm, "f": freqs, "zeta": zetas}}
    if mode_shapes is not None:
        extra["mode_shapes"] = mode_shapes
    if found:
        extra["tables"]["campbell_crossings.csv"] = cross_table
    return Result(summary=summary, extra=extra)


# -- converged diagram (&refinement levels > 1) -----------------------------------------------

def _extrapolated(values: list, expected_order: float):
    """Richardson over the levels: the last three (observed order), or two (expected order)."""
    if len(values) == 2:
        return richardson_two(*values, expected_order=expected_order)
    return richardson(*values[-3:], expected_order=expected_order)


def refine_frequencies(freqs: list, expected_order: float) -> dict:
    """Richardson of every tracked frequency at every speed, from the diagrams at n, 2n, 4n ...

    Parameters
    ----------
    freqs : list of ndarray
        Each level's (n_speeds, n_modes) frequencies [Hz], coarse to fine, on the same speed grid
        and matched by mode number (the modes are numbered by frequency at the first speed and
        followed by MAC, at every level alike).
    expected_order : float

    Returns
    -------
    dict
        ``extrapolated``, ``error``, ``order`` (n_speeds, n_modes; NaN where a level does not
        oscillate: an overdamped or zero-stiffness mode has no frequency to extrapolate, and
        where the extrapolation leaves the physical range), ``doubtful`` (bool: Richardson's
        warning, not in the asymptotic range or oscillating) and ``refused`` (int: -1, or where the
        extrapolation is below 0 Hz or its error estimate exceeds it,
        :func:`pydriver.richardson.outside_physical_range`, the index of the level that departs
        from the others, the finest of two levels).
    """
    f = np.stack([np.asarray(x, float) for x in freqs])
    out = {k: np.full(f.shape[1:], np.nan) for k in ("extrapolated", "error", "order")}
    out["doubtful"] = np.zeros(f.shape[1:], bool)
    out["refused"] = np.full(f.shape[1:], -1)
    for idx in np.ndindex(*f.shape[1:]):
        values = f[(slice(None), *idx)]
        if not np.all(values > 0.0):
            continue
        e = _extrapolated([float(v) for v in values], expected_order)
        if outside_physical_range(e) is not None:
            k = departing_level(values)
            out["refused"][idx] = len(values) - 1 if k is None else k
            continue
        out["extrapolated"][idx], out["error"][idx], out["order"][idx] = (e.extrapolated, e.error_estimate,
                                                                          e.observed_order)
        out["doubtful"][idx] = bool(e.warning) and len(values) > 2
    return out


def _by_pair(found: list) -> dict:
    """{(mode, harmonic): [rpm, ...] ascending} of a crossing list."""
    out: dict = {}
    for c in sorted(found, key=lambda c: c["rpm"]):
        out.setdefault((c["mode"], c["harmonic"]), []).append(c["rpm"])
    return out


def refine_crossings(diagrams: list, ns: list, harmonics, op, expected_order: float) -> tuple:
    """Every crossing speed in the operating range with its Richardson value, order and error.

    Each level's crossings are found over the whole diagram (not only in the operating range:
    a crossing just outside it at n may be inside at 4n) and matched across levels by (mode,
    harmonic), the j-th crossing of a pair with the j-th.  A crossing is reported when the
    finest level's speed or the extrapolated one lies in the operating range.  A pair that
    crosses a different number of times at different levels cannot be matched: it is reported
    (with the levels' speeds in range, NaN where a level has none) and warned about, never
    dropped.

    The speeds are those of the linear interpolation between grid speeds (:func:`crossings`),
    which is the same at every level: extrapolation removes the error of the discretisation in
    n, not that of the speed grid (O(step^2) times the curvature of f(rpm) minus k rpm).

    Parameters
    ----------
    diagrams : list of (rpm, freqs)
        Each level's speed grid [rpm] and (n_speeds, n_modes) frequencies [Hz], coarse to fine.
    ns : list of int
        The levels' numbers of bodies.
    harmonics : int or sequence of int
        As :func:`crossings`.
    op : (float, float)
        Operating range [rpm].
    expected_order : float

    Returns
    -------
    rows : list of dict
        ``mode``, ``harmonic``, ``rpm`` (the finest level's, NaN if it has none),
        ``frequency_hz``, ``rpm_n<n>`` per level, ``rpm_extrapolated``, ``rpm_error``,
        ``rpm_order``, ``f_extrapolated_hz``, ``f_error_hz``, ``f_order``, ``matched`` and
        ``warning`` (Richardson's, or why the crossing is not matched).
    warnings : list of str
    """
    levels = [_by_pair(crossings(rpm, f, harmonics, (float(rpm[0]), float(rpm[-1])))) for rpm, f in diagrams]
    inside = lambda r: op[0] <= r <= op[1]                                     # noqa: E731
    rows, unmatched, refused = [], [], []
    for key in sorted(set().union(*levels)):
        mode, k = key
        lists = [lvl.get(key, []) for lvl in levels]
        if len({len(x) for x in lists}) == 1:
            for j in range(len(lists[0])):
                values = [x[j] for x in lists]
                e = _extrapolated(values, expected_order)
                why = outside_physical_range(e)
                if why is not None:
                    rows += _refused_crossing(mode, k, values, ns, e, why, inside, refused)
                    continue
                if not (inside(values[-1]) or inside(e.extrapolated)):
                    continue
                row = {"mode": mode, "harmonic": k, "rpm": values[-1], "frequency_hz": k * values[-1] / 60.0}
                row.update({f"rpm_n{n}": v for n, v in zip(ns, values)})
                row.update(rpm_extrapolated=e.extrapolated, rpm_error=e.error_estimate, rpm_order=e.observed_order,
                           f_extrapolated_hz=k * e.extrapolated / 60.0, f_error_hz=k * e.error_estimate / 60.0,
                           f_order=e.observed_order, matched=True, warning=e.warning or "")
                rows.append(row)
            continue
        in_range = [[r for r in x if inside(r)] for x in lists]
        if not any(in_range):
            continue
        values = [x[0] if x else float("nan") for x in in_range]
        present = [n for n, x in zip(ns, lists) if x]
        absent = [n for n, x in zip(ns, lists) if not x]
        why = (f"mode {mode} x {k}/rev crosses {', '.join(str(len(x)) for x in lists)} times at n = "
               f"{', '.join(str(n) for n in ns)}" + (f" (none at n = {', '.join(map(str, absent))})" if absent else "")
               + ": not matched across levels, not extrapolated")
        row = {"mode": mode, "harmonic": k, "rpm": values[-1], "frequency_hz": k * values[-1] / 60.0}
        row.update({f"rpm_n{n}": v for n, v in zip(ns, values)})
        row.update(rpm_extrapolated=float("nan"), rpm_error=float("nan"), rpm_order=float("nan"),
                   f_extrapolated_hz=float("nan"), f_error_hz=float("nan"), f_order=float("nan"), matched=False,
                   warning=why)
        rows.append(row)
        unmatched.append((why, present))
    rows.sort(key=lambda r: (r["rpm_extrapolated"] if np.isfinite(r["rpm_extrapolated"])
                             else np.nanmax([r[f"rpm_n{n}"] for n in ns])))
    warnings = [f"refinement: crossing {why}; it is in the operating range at n = {', '.join(map(str, present))}"
                for why, present in unmatched]
    if refused:
        warnings.append("refinement: crossing speeds whose extrapolation leaves the physical range are no result "
                        "and are not extrapolated (campbell_crossings.csv: blank), nor reported where the finest "
                        "level is the one that departs: " + "; ".join(refused))
    doubtful = [f"mode {r['mode']} x {r['harmonic']}/rev" for r in rows if r["matched"] and r["warning"]
                and len(ns) > 2 and np.isfinite(r["rpm_extrapolated"])]
    if doubtful:
        warnings.append("refinement: crossing speeds not in the asymptotic range (observed order far from "
                        f"{expected_order:g}, or oscillating; error bars widened): " + ", ".join(doubtful))
    return rows, warnings


def _refused_crossing(mode, k, values, ns, e, why, inside, refused: list) -> list[dict]:
    """The row of a crossing whose extrapolation leaves the physical range (issue 35: -78.7 +-
    236 rpm from 234.4, 236.1 and 0.0119 rpm at n = 11, 22, 44): the levels' speeds, no
    extrapolation, the finest level's speed as the crossing's only where that level is not the
    one that departs from the others; its sentence goes to ``refused``.  No row when no level
    has it in the operating range."""
    if not any(inside(v) for v in values):
        return []
    odd = departing_level(values)
    finest = values[-1] if odd != len(values) - 1 else float("nan")
    row = {"mode": mode, "harmonic": k, "rpm": finest, "frequency_hz": k * finest / 60.0}
    row.update({f"rpm_n{n}": v for n, v in zip(ns, values)})
    row.update(rpm_extrapolated=float("nan"), rpm_error=float("nan"), rpm_order=float("nan"),
               f_extrapolated_hz=float("nan"), f_error_hz=float("nan"), f_order=float("nan"), matched=True,
               warning=f"extrapolated {e.extrapolated:.4g} +- {e.error_estimate:.3g} rpm: {why}")
    refused.append(f"mode {mode} x {k}/rev ({', '.join(f'{v:.4g}' for v in values)} rpm at n = "
                   f"{', '.join(map(str, ns))} extrapolate to {e.extrapolated:.4g} +- {e.error_estimate:.3g} rpm: "
                   f"{why}; {level_text(odd, ns)} departs from the others)")
    return [row]


def _json_number(x) -> float | None:
    """A float for summary.json, None for NaN (the summary is strict JSON)."""
    x = float(x)
    return x if np.isfinite(x) else None


def refine_diagram(results: list, ns: list, expected_order: float) -> tuple[dict, list]:
    """The converged Campbell diagram from the diagrams at ns = (n, 2n, 4n ...): adds the
    extrapolated frequencies to the finest result's campbell.csv and extra['campbell'], its
    crossings' extrapolated speeds to campbell_crossings.csv and summary['crossings'].

    Returns summary['refinement'] (quantities: every crossing speed in the operating range and
    the lowest frequency there) and the warnings.
    """
    fine = results[-1]
    s = fine.summary
    rpm = np.asarray(s["rpm"], float)
    for r in results[:-1]:
        if not np.array_equal(np.asarray(r.summary["rpm"], float), rpm):
            raise RunError(f"Campbell refinement: the levels' speed grids differ (n = {ns})")
    op = tuple(s["operating_rpm"])
    freqs = [np.asarray(r.extra["campbell"]["f"], float) for r in results]
    conv = refine_frequencies(freqs, expected_order)
    table = fine.extra["tables"]["campbell.csv"]
    table["f_extrapolated_hz"] = conv["extrapolated"].reshape(-1)
    table["f_error_hz"] = conv["error"].reshape(-1)
    table["f_order"] = conv["order"].reshape(-1)
    fine.extra["campbell"].update(f_extrapolated=conv["extrapolated"], f_error=conv["error"])
    rows, warnings = refine_crossings([(rpm, f) for f in freqs], ns, s.get("excited_harmonics", int(s["harmonics"])),
                                      op, expected_order)
    keys = ["mode", "harmonic", "rpm", "frequency_hz", *[f"rpm_n{n}" for n in ns], "rpm_extrapolated", "rpm_error",
            "rpm_order", "f_extrapolated_hz", "f_error_hz", "f_order"]
    if rows:
        fine.extra["tables"]["campbell_crossings.csv"] = {k: np.array([r[k] for r in rows], float) for k in keys}
    else:
        fine.extra["tables"].pop("campbell_crossings.csv", None)
    s["crossings"] = [{k: (_json_number(v) if isinstance(v, float) else v) for k, v in r.items()}
                      for r in rows if np.isfinite(r["rpm"])]
    quantities = {}
    for r in rows:
        if not r["matched"] or not np.isfinite(r["rpm_extrapolated"]):
            continue
        name = f"mode {r['mode']} x {r['harmonic']}/rev [rpm]"
        quantities[name] = {"values": [r[f"rpm_n{n}"] for n in ns], "extrapolated": r["rpm_extrapolated"],
                            "observed_order": r["rpm_order"], "order_observed": len(ns) > 2,
                            "error_estimate": r["rpm_error"], "warning": r["warning"]}
    lowest = [r.summary["lowest_frequency_hz"] for r in results]
    if all(x > 0.0 for x in lowest):
        e = _extrapolated(lowest, expected_order)
        why = outside_physical_range(e)
        if why is None:
            quantities["lowest f in range [Hz]"] = {
                "values": lowest, "extrapolated": e.extrapolated, "observed_order": e.observed_order,
                "order_observed": len(ns) > 2, "error_estimate": e.error_estimate, "warning": e.warning or ""}
        else:
            warnings.append(f"refinement: the lowest frequency in the operating range, {', '.join(f'{x:.4g}' for x in lowest)} "
                            f"Hz at n = {', '.join(map(str, ns))}, extrapolates to {e.extrapolated:.4g} +- "
                            f"{e.error_estimate:.3g} Hz: {why}; no result (not in refinement.csv); "
                            f"{level_text(departing_level(lowest), ns)} departs from the others")
    if np.any(conv["doubtful"]):
        modes = sorted({int(m) + 1 for m in np.nonzero(conv["doubtful"])[1]})
        warnings.append(f"refinement: at {int(np.count_nonzero(conv['doubtful']))} of {conv['doubtful'].size} "
                        "(speed, mode) points of the diagram the frequencies are not in the asymptotic range "
                        f"(observed order far from {expected_order:g}, or oscillating; error bars widened): "
                        f"modes {', '.join(map(str, modes))} (campbell.csv f_order)")
    refused = conv["refused"] >= 0
    if np.any(refused):
        worst = np.bincount(conv["refused"][refused], minlength=len(ns))
        odd = int(np.argmax(worst)) if len(ns) > 2 else None
        modes = sorted({int(m) + 1 for m in np.nonzero(refused)[1]})
        warnings.append(f"refinement: at {int(np.count_nonzero(refused))} of {refused.size} (speed, mode) points the "
                        "extrapolated frequency leaves the physical range (below 0 Hz, or an error estimate larger "
                        f"than the frequency): no result, not extrapolated there (campbell.csv f_extrapolated_hz "
                        f"blank), modes {', '.join(map(str, modes))}; the level that departs from the others: "
                        f"{level_text(odd, ns)}" + (f" at {int(worst[odd])} of them" if odd is not None else "")
                        + " (modes numbered by frequency at the first speed: a level with other modes at the bottom "
                        "numbers them differently)")
    missing = ~np.isfinite(conv["extrapolated"]) & (freqs[-1] > 0.0) & ~refused
    if np.any(missing):
        warnings.append(f"refinement: {int(np.count_nonzero(missing))} (speed, mode) points oscillate at n = {ns[-1]} "
                        "but not at every coarser level: not extrapolated there (campbell.csv f_extrapolated_hz NaN)")
    return {"n": ns, "expected_order": expected_order, "quantities": quantities}, warnings
