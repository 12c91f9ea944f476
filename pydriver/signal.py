"""Decay-signal analysis (thesis section 5.4, Figure 5.8): first damped frequency and damping.

numpy's FFT (pocketfft) gives the spectrum for plots; the frequency itself comes from the
zero crossings of the decay about the equilibrium value, which resolve it far below the
FFT bin width of a 1 s record (1 Hz) without windowing bias.
"""

from __future__ import annotations

import numpy as np


def zero_crossings(t, y):
    """Times where y changes sign (linear interpolation between samples)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    idx = np.where(np.signbit(y[:-1]) != np.signbit(y[1:]))[0]
    return t[idx] - y[idx] / (y[idx + 1] - y[idx]) * (t[idx + 1] - t[idx])


def spectrum(t, y):
    """One-sided amplitude spectrum of y (Hann window, zero padded); returns (f [Hz], |Y|)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float) - np.mean(y)
    n = 1 << max(14, int(np.ceil(np.log2(len(y)))) + 4)
    dt = t[1] - t[0]
    spec = np.abs(np.fft.rfft(y * np.hanning(len(y)), n=n)) * 2 / np.sum(np.hanning(len(y)))
    return np.fft.rfftfreq(n, dt), spec


def decay_analysis(t, signal, name: str, pulse_end: float, settle: float = 0.1) -> dict:
    """First damped frequency and damping ratio of a free decay.

    Parameters
    ----------
    t, signal : array
        Time [s] and signal (e.g. a CM coordinate [m]); ``signal[0]`` is the equilibrium.
    name : str
        Column name of the signal (reported).
    pulse_end : float
        End of the excitation [s]; the analysis starts ``settle`` seconds later, when the
        higher modes (more damped) have died out.

    Returns
    -------
    dict with ``f_damped_hz`` (from the mean half period between zero crossings),
    ``f_fft_peak_hz``, ``zeta`` (from the logarithmic decrement of the peaks), the window and
    the number of zero crossings used; without those three (and with a ``note`` saying why)
    when the run has no free decay long enough to evaluate.
    """
    t = np.asarray(t, float)
    y = np.asarray(signal, float) - float(signal[0])
    m = t >= pulse_end + settle
    if np.count_nonzero(m) < 3:
        # The run ends before the free decay starts: nothing to analyse (not an error).
        return {"signal": name, "window_s": [], "n_zero_crossings": 0,
                "note": f"run ends before t = {pulse_end + settle:g} s, no free decay to analyse"}
    tc = zero_crossings(t[m], y[m])
    out = {"signal": name, "window_s": [float(t[m][0]), float(t[m][-1])], "n_zero_crossings": int(len(tc))}
    if len(tc) < 3:
        out["note"] = f"{len(tc)} zero crossings after t = {pulse_end + settle:g} s: too few to evaluate"
        return out
    f_d = (len(tc) - 1) / (2.0 * (tc[-1] - tc[0]))
    f, spec = spectrum(t[m], y[m])
    # Peaks between consecutive crossings: slope of log|peak| over time = -zeta w_n.
    peaks_t, peaks_a = [], []
    for a, b in zip(tc[:-1], tc[1:]):
        w = (t[m] >= a) & (t[m] <= b)
        if np.any(w):
            k = np.argmax(np.abs(y[m][w]))
            peaks_t.append(t[m][w][k])
            peaks_a.append(abs(y[m][w][k]))
    out.update(f_damped_hz=float(f_d), f_fft_peak_hz=float(f[np.argmax(spec)]))
    if len(peaks_t) > 2 and min(peaks_a) > 0.0:
        sigma = -np.polyfit(peaks_t, np.log(peaks_a), 1)[0]
        out["zeta"] = float(sigma / np.hypot(sigma, 2 * np.pi * f_d))
    return out
