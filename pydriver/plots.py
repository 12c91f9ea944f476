"""PNG plots (matplotlib, Agg backend).

plot_result() draws what one run shows (shape, reactions, decay signal and spectrum, mode
frequencies) into a run's (temporary) directory and returns the file names.  The study
plots (rest vs hover shapes like thesis Figures 5.6/5.12, frequency against c_y like
Figure 5.9) are drawn by plot_shapes() and plot_frequency_vs_cy().
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, out: Path, name: str) -> str:
    plt = _plt()
    fig.savefig(Path(out) / name, dpi=110)
    plt.close(fig)
    return name


def _save_replace(fig, path: Path):
    """Save to a temporary name beside ``path`` and rename: a study plot is never half written."""
    plt = _plt()
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".png", dir=path.parent)
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def _shape_axes(fig, tables: dict):
    """3D view and two side views (y-z, x-y) of CM polylines, one line per label."""
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    for label, t in tables.items():
        ax.plot(t["x_m"], t["y_m"], t["z_m"], "o-", ms=3, label=label)
    ax.set_xlabel("x [m]"); ax.set_ylabel("y [m]"); ax.set_zlabel("z [m]")
    for k, (a, b) in enumerate((("y_m", "z_m"), ("x_m", "y_m"))):
        ax2 = fig.add_subplot(1, 3, k + 2)
        for label, t in tables.items():
            ax2.plot(t[a], t[b], "o-", ms=3, label=label)
        ax2.set_xlabel(a.replace("_m", " [m]")); ax2.set_ylabel(b.replace("_m", " [m]"))
        ax2.set_aspect("equal", adjustable="datalim"); ax2.grid(True)
    ax2.legend(fontsize=7)


def plot_result(result, out: Path) -> list[str]:
    """Plots of one run, written into the directory ``out``; returns their file names."""
    return list(_plots(result, out))


def _plots(result, out: Path):
    plt = _plt()
    s = result.summary
    if result.table is not None:
        fig = plt.figure(figsize=(12, 4))
        _shape_axes(fig, {s["case"]: result.table})
        fig.suptitle(f"{s['case']}: centres of mass")
        yield _save(fig, out, "shape.png")
    if result.timeseries is not None:
        ts = result.timeseries
        fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for name in [n for n in ts if n[:2] in ("FA", "FB")]:
            ax[0].plot(ts["t"], ts[name], label=name)
        for name in [n for n in ts if n[:2] in ("MA", "MB")]:
            ax[1].plot(ts["t"], ts[name], label=name)
        ax[0].set_ylabel("force [N]"); ax[1].set_ylabel("moment [Nm]"); ax[1].set_xlabel("t [s]")
        for a in ax:
            a.grid(True); a.legend(fontsize=7, ncol=3)
        fig.suptitle(f"{s['case']}: support reactions (support on chain)")
        yield _save(fig, out, "reactions.png")
    if "f_damped_hz" in s.get("decay", {}):
        from pydriver.signal import spectrum
        d = s["decay"]
        t = result.timeseries["t"]
        y = result.timeseries[d["signal"]] - result.timeseries[d["signal"]][0]
        fig, ax = plt.subplots(2, 1, figsize=(8, 6))
        ax[0].plot(t, y * 1e3)
        ax[0].axvspan(*d["window_s"], color="0.9", label="evaluated")
        ax[0].set_xlabel("t [s]"); ax[0].set_ylabel(f"{d['signal']} - rest [mm]"); ax[0].legend()
        m = t >= d["window_s"][0]
        f, spec = spectrum(t[m], y[m])
        ax[1].plot(f, spec * 1e3)
        ax[1].set_xlim(0, 200); ax[1].set_xlabel("f [Hz]"); ax[1].set_ylabel("amplitude [mm]")
        ax[1].axvline(d["f_damped_hz"], color="r", ls="--", label=f"{d['f_damped_hz']:.2f} Hz")
        ax[1].legend()
        for a in ax:
            a.grid(True)
        fig.suptitle(f"{s['case']}: decay test (thesis Figure 5.8)")
        yield _save(fig, out, "decay.png")
    if "frequencies_hz" in s:
        fig, ax = plt.subplots(figsize=(7, 4))
        k = range(1, len(s["frequencies_hz"]) + 1)
        ax.semilogy(k, s["frequencies_hz"], "o", label="undamped")
        ax.semilogy(k, [f if f > 0 else float("nan") for f in s["damped_frequencies_hz"]], "x", label="damped")
        ax.set_xlabel("mode"); ax.set_ylabel("f [Hz]"); ax.grid(True); ax.legend()
        fig.suptitle(f"{s['case']}: natural frequencies")
        yield _save(fig, out, "frequencies.png")


def plot_shapes(tables: dict, path: Path, title: str):
    """Rest vs hover (or any set of) shapes in 3D and two side views, to ``path``."""
    plt = _plt()
    fig = plt.figure(figsize=(13, 4.5))
    _shape_axes(fig, tables)
    fig.suptitle(title)
    _save_replace(fig, path)


def plot_frequency_vs_cy(res: dict, path: Path, f_flap: float, c_cross: float):
    """First frequency against c_y (thesis Figure 5.9) with the flap frequency line."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(res["c_y"], res["f_damped_hz"], "o-", label="first damped frequency")
    ax.plot(res["c_y"], res["f_undamped_hz"], "--", label="first undamped frequency")
    ax.axhline(f_flap, color="r", ls=":", label=f"flap frequency {f_flap} Hz")
    ax.axvline(c_cross, color="k", ls=":", label=f"c_y = {c_cross:.2f} Nm/rad")
    ax.set_xlabel("c_y [Nm/rad]"); ax.set_ylabel("f [Hz]"); ax.grid(True); ax.legend()
    fig.suptitle("UH-60 cable part 2: first frequency against c_y (thesis Figure 5.9)")
    _save_replace(fig, path)
