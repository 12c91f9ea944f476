"""Floquet stability of a periodic motion (issue 21, item 4).

The monodromy matrix Phi (2 nf x 2 nf, ``CoreModel.monodromy``: the variational equations
integrated with the state, in the independent coordinates on the constraint manifold, so the
constraints add no spurious multipliers) maps a perturbation of the periodic state over one
period T.  Its eigenvalues are the Floquet multipliers rho; the motion is asymptotically stable
when every |rho| < 1.  Each multiplier gives a characteristic exponent eta = ln(rho) / T
(principal branch), whose imaginary part is fixed only modulo 2 pi / T: the frequency is known
modulo 1/rev.  It is resolved by the nearest hover mode, matched on the whole complex exponent
(the hover eigenvalue s = -zeta w_n + i w_d from ``damped_frequencies_hz`` and
``damping_ratios`` of the flight summary, :mod:`pydriver.analyses.hover_modes`): matching on the
frequency alone let round-off multipliers (|rho| ~ 1e-17, their phase meaningless) take hover
modes first, and a well-resolved mode then got another mode's frequency.  Multipliers below
the resolution of Phi (a tenth of the integration's rtol times the largest |rho|) are not
matched.  The
damping ratio follows from the resolved exponent, zeta = -Re(eta) / |eta| (Peters & Hohenemser
1971; Friedmann & Hammond 1983; docs/model.md "Floquet stability").
"""

from __future__ import annotations

import numpy as np

#: Multipliers below FLOOR_SHARE rtol |rho|_max are round-off (the whole monodromy's and the
#: subspace's, pydriver.analyses.floquet_subspace): the columns' integration errors,
#: of the order of rtol times the least damped mode's share of an image, turn the round-off
#: multipliers (|rho| ~ 1e-17 in the whole monodromy) into spurious ones.  Measured on the main
#: job at n = 11: the largest spurious multiplier was 0.012 rtol |rho|_max at rtol = 1e-6 and
#: 0.017 rtol |rho|_max at 1e-8, while the physical 1.7e-7 agreed between the two rtol to
#: 2.4e-4 relative (and with the whole monodromy's eigenvalue to 1e-3): 0.1 keeps a factor 6
#: above the noise and resolves the 1.7e-7 (15 x the floor at rtol = 1e-6).
FLOOR_SHARE = 0.1


def _candidates(f0: float, period: float, top: float) -> np.ndarray:
    """The frequencies [Hz] an exponent with principal frequency f0 may stand for: k/T +- f0."""
    k = np.arange(0, int(np.ceil(top * period)) + 2)
    return np.concatenate([k / period + f0, k / period - f0])


def hover_eigenvalues(hover_hz, hover_zeta=None) -> np.ndarray:
    """The hover modes' eigenvalues s = -zeta w_n + i w_d [1/s] (w_n = w_d / sqrt(1 - zeta^2));
    overdamped modes (frequency 0) have no oscillation to resolve and are left out."""
    f = np.asarray(list(hover_hz), float)
    z = np.zeros_like(f) if hover_zeta is None else np.asarray(list(hover_zeta), float)[:f.size]
    keep = f > 0.0
    w_d = 2.0 * np.pi * f[keep]
    zeta = np.clip(z[keep], 0.0, 1.0 - 1e-12)
    return -zeta * w_d / np.sqrt(1.0 - zeta ** 2) + 1j * w_d


def floquet_modes(phi: np.ndarray, period: float, hover_hz=(), hover_zeta=None,
                  resolution: float = 1.0e-8) -> dict:
    """Multipliers, exponents, resolved frequencies and damping ratios of a monodromy matrix.

    Parameters
    ----------
    phi : (m, m) array
        Monodromy matrix over one period.
    period : float
        The period T [s].
    hover_hz, hover_zeta : sequences of float
        Damped frequencies [Hz] and damping ratios of the modes that resolve the 1/rev
        ambiguity (frequency 0 = overdamped, not used; no ratios: matched as undamped).
    resolution : float
        Relative accuracy of Phi (the integration's rtol): multipliers below
        ``FLOOR_SHARE`` resolution max|rho| are round-off and are not matched to a hover mode.

    Returns
    -------
    dict
        Columns of ``floquet.csv``, one row per mode: a complex-conjugate pair of multipliers
        is one mode (the one with Im rho >= 0), a real multiplier one mode; least damped first.
    """
    phi = np.asarray(phi, float)
    rho = np.linalg.eigvals(phi)
    # The integration's errors reach a multiplier as rtol times the least damped mode's share of
    # a column, not of ||Phi||_2 (which x's mixed units, rad and rad/s, inflate): the old floor
    # 10 rtol ||Phi||_2 = 1.2e-4 of the main job at n = 11 discarded its 40 and 49 Hz modes
    # (1.5e-5, 1.7e-7), which agree with a subspace at tight column tolerances to 4.5e-4 and
    # 1.2e-3 (the other eigenvalues of Phi are below 1.5e-16); FLOOR_SHARE above.
    floor = FLOOR_SHARE * resolution * float(np.max(np.abs(rho), initial=0.0))
    return modes_of_multipliers(rho, period, hover_hz, hover_zeta, np.abs(rho) >= floor)


def modes_of_multipliers(rho, period: float, hover_hz=(), hover_zeta=None, resolved=None) -> dict:
    """:func:`floquet_modes` of given multipliers (the whole monodromy's eigenvalues, or the
    Ritz values of a subspace, :mod:`pydriver.analyses.floquet_subspace`); ``resolved`` (bool per
    multiplier, default all) says which are above round-off and are matched to a hover mode."""
    rho = np.asarray(rho, complex)
    resolved = np.ones(rho.size, bool) if resolved is None else np.asarray(resolved, bool)
    keep = rho.imag >= -1e-14 * np.maximum(1.0, np.abs(rho))
    # A conjugate pair is one mode: drop the lower member (eig returns both).
    rho, resolved = rho[keep], resolved[keep]
    size = np.maximum(np.abs(rho), np.finfo(float).tiny)
    eta = (np.log(size) + 1j * np.angle(rho)) / period
    f0 = np.abs(eta.imag) / (2.0 * np.pi)
    s_hover = hover_eigenvalues(hover_hz, hover_zeta)
    freq, matched = f0.copy(), np.full(len(rho), np.nan)
    if s_hover.size and np.any(resolved):
        top = float(s_hover.imag.max()) / (2.0 * np.pi)
        # Greedy assignment on the relative distance between a hover eigenvalue and the nearest
        # of an exponent's branches Re(eta) + i 2 pi f, f in k/T +- f0.
        idx = np.flatnonzero(resolved)
        dist = np.full((len(rho), s_hover.size), np.inf)
        best = np.zeros((len(rho), s_hover.size))
        for i in idx:
            cands = _candidates(f0[i], period, top)
            cands = cands[cands >= 0.0]
            branch = eta[i].real + 2j * np.pi * cands
            for j, sj in enumerate(s_hover):
                d = np.abs(branch - sj)
                k = int(np.argmin(d))
                dist[i, j], best[i, j] = d[k] / abs(sj), cands[k]
        taken_i, taken_j = set(), set()
        for flat in np.argsort(dist, axis=None):
            i, j = np.unravel_index(flat, dist.shape)
            if not np.isfinite(dist[i, j]):
                break
            if i in taken_i or j in taken_j:
                continue
            taken_i.add(i)
            taken_j.add(j)
            freq[i], matched[i] = best[i, j], s_hover[j].imag / (2.0 * np.pi)
            if len(taken_i) == idx.size or len(taken_j) == s_hover.size:
                break
    omega = 2.0 * np.pi * freq
    mag = np.hypot(eta.real, omega)
    zeta = np.where(mag > 0.0, -eta.real / np.where(mag > 0.0, mag, 1.0), 0.0)
    order = np.argsort(-np.abs(rho))
    cols = {"mode": np.arange(1, len(rho) + 1), "multiplier_re": rho.real[order], "multiplier_im": rho.imag[order],
            "multiplier_abs": np.abs(rho)[order], "exponent_re_per_s": eta.real[order],
            "exponent_im_per_s": eta.imag[order], "frequency_hz": freq[order],
            "hover_frequency_hz": matched[order], "damping_ratio": zeta[order],
            "resolved": resolved[order].astype(int)}
    return cols


def floquet_summary(cols: dict, period: float) -> dict:
    """summary['floquet']: stable or not (every |rho| < 1), the largest |rho|, and the least
    damped mode (smallest damping ratio) with its frequency."""
    if not len(cols["mode"]):
        return {"stable": True, "n_modes": 0}
    # The least damped of the resolved modes: a round-off multiplier's exponent means nothing.
    zeta = np.where(np.asarray(cols.get("resolved", np.ones(len(cols["mode"]))), bool), cols["damping_ratio"], np.inf)
    i = int(np.argmin(zeta)) if np.isfinite(zeta).any() else int(np.argmin(cols["damping_ratio"]))
    return {"stable": bool(np.all(cols["multiplier_abs"] < 1.0)),
            "max_multiplier_abs": float(np.max(cols["multiplier_abs"])),
            "least_damped": {"damping_ratio": float(cols["damping_ratio"][i]),
                             "frequency_hz": float(cols["frequency_hz"][i]),
                             "multiplier_abs": float(cols["multiplier_abs"][i]),
                             "hover_frequency_hz": (None if np.isnan(cols["hover_frequency_hz"][i])
                                                    else float(cols["hover_frequency_hz"][i]))},
            "period_s": float(period), "n_modes": int(len(cols["mode"])),
            "coordinates": "independent coordinates on the constraint manifold (2 nf)"}


def add_floquet(model, result, phi: np.ndarray, period: float) -> None:
    """Put the Floquet modes of a flight result's monodromy into its summary and tables."""
    hover = result.summary.get("damped_frequencies_hz") or ()
    zeta = result.summary.get("damping_ratios")
    cols = floquet_modes(phi, period, hover, zeta, resolution=model.solver_settings()["rtol"])
    result.summary["floquet"] = floquet_summary(cols, period)
    result.extra.setdefault("tables", {})["floquet.csv"] = cols
    if not result.summary["floquet"]["stable"]:
        result.summary.setdefault("warnings", []).append(
            f"the periodic motion is unstable: a Floquet multiplier has |rho| = "
            f"{result.summary['floquet']['max_multiplier_abs']:.6g} > 1 (floquet.csv)")
