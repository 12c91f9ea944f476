"""Floquet stability of a periodic motion (issue 21, item 4).

The monodromy matrix Phi (2 nf x 2 nf, ``CoreModel.monodromy``: IDAS forward sensitivities in
the independent coordinates on the constraint manifold, so the constraints add no spurious
multipliers) maps a perturbation of the periodic state over one period T.  Its eigenvalues are
the Floquet multipliers rho; the motion is asymptotically stable when every |rho| < 1.  Each
multiplier gives a characteristic exponent eta = ln(rho) / T (principal branch), whose imaginary
part is fixed only modulo 2 pi / T: the frequency Im(eta) / 2 pi is known modulo 1/rev.  It is
resolved by the nearest of the hover modes' damped frequencies (``damped_frequencies_hz`` of the
flight summary, :mod:`pydriver.analyses.hover_modes`), and the damping ratio follows from the
resolved exponent, zeta = -Re(eta) / |eta| (Peters & Hohenemser 1971; Friedmann & Hammond 1983;
docs/model.md "Floquet stability").
"""

from __future__ import annotations

import numpy as np


def _candidates(f0: float, period: float, top: float) -> np.ndarray:
    """The frequencies [Hz] an exponent with principal frequency f0 may stand for: k/T +- f0."""
    k = np.arange(0, int(np.ceil(top * period)) + 2)
    return np.concatenate([k / period + f0, k / period - f0])


def floquet_modes(phi: np.ndarray, period: float, hover_hz=()) -> dict:
    """Multipliers, exponents, resolved frequencies and damping ratios of a monodromy matrix.

    Parameters
    ----------
    phi : (m, m) array
        Monodromy matrix over one period.
    period : float
        The period T [s].
    hover_hz : sequence of float
        Damped frequencies [Hz] that resolve the 1/rev ambiguity (0 = overdamped, not used).

    Returns
    -------
    dict
        Columns of ``floquet.csv``, one row per mode: a complex-conjugate pair of multipliers
        is one mode (the one with Im rho >= 0), a real multiplier one mode; least damped first.
    """
    rho = np.linalg.eigvals(np.asarray(phi, float))
    keep = rho.imag >= -1e-14 * np.maximum(1.0, np.abs(rho))
    # A conjugate pair is one mode: drop the lower member (eig returns both).
    rho = rho[keep]
    size = np.maximum(np.abs(rho), np.finfo(float).tiny)
    eta = (np.log(size) + 1j * np.angle(rho)) / period
    f0 = np.abs(eta.imag) / (2.0 * np.pi)
    hover = np.array([h for h in hover_hz if h > 0.0], float)
    freq, matched = f0.copy(), np.full(len(rho), np.nan)
    if hover.size and len(rho):
        top = float(hover.max())
        # Greedy assignment on the distance between a hover mode and a mode's nearest candidate.
        dist = np.empty((len(rho), hover.size))
        best = np.empty((len(rho), hover.size))
        for i, f in enumerate(f0):
            cands = _candidates(f, period, top)
            cands = cands[cands >= 0.0]
            for j, h in enumerate(hover):
                k = int(np.argmin(np.abs(cands - h)))
                dist[i, j], best[i, j] = abs(cands[k] - h), cands[k]
        taken_i, taken_j = set(), set()
        for flat in np.argsort(dist, axis=None):
            i, j = np.unravel_index(flat, dist.shape)
            if i in taken_i or j in taken_j:
                continue
            taken_i.add(i)
            taken_j.add(j)
            freq[i], matched[i] = best[i, j], hover[j]
            if len(taken_i) == len(rho) or len(taken_j) == hover.size:
                break
    omega = 2.0 * np.pi * freq
    mag = np.hypot(eta.real, omega)
    zeta = np.where(mag > 0.0, -eta.real / np.where(mag > 0.0, mag, 1.0), 0.0)
    order = np.argsort(-np.abs(rho))
    cols = {"mode": np.arange(1, len(rho) + 1), "multiplier_re": rho.real[order], "multiplier_im": rho.imag[order],
            "multiplier_abs": np.abs(rho)[order], "exponent_re_per_s": eta.real[order],
            "exponent_im_per_s": eta.imag[order], "frequency_hz": freq[order],
            "hover_frequency_hz": matched[order], "damping_ratio": zeta[order]}
    return cols


def floquet_summary(cols: dict, period: float) -> dict:
    """summary['floquet']: stable or not (every |rho| < 1), the largest |rho|, and the least
    damped mode (smallest damping ratio) with its frequency."""
    if not len(cols["mode"]):
        return {"stable": True, "n_modes": 0}
    i = int(np.argmin(cols["damping_ratio"]))
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
    cols = floquet_modes(phi, period, hover)
    result.summary["floquet"] = floquet_summary(cols, period)
    result.extra.setdefault("tables", {})["floquet.csv"] = cols
    if not result.summary["floquet"]["stable"]:
        result.summary.setdefault("warnings", []).append(
            f"the periodic motion is unstable: a Floquet multiplier has |rho| = "
            f"{result.summary['floquet']['max_multiplier_abs']:.6g} > 1 (floquet.csv)")
