"""PNG plots of results (matplotlib, Agg backend); each written to a temporary name."""

from __future__ import annotations

import tempfile
from pathlib import Path


def plot_result(result, out: Path):
    """Plot a result; yield (temporary path, final path) pairs for the caller to rename."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []
    if result.table is not None:
        t = result.table
        fig = plt.figure(figsize=(10, 4))
        ax = fig.add_subplot(1, 3, 1, projection="3d")
        ax.plot(t["x_m"], t["y_m"], t["z_m"], "o-")
        ax.set_xlabel("x [m]"); ax.set_ylabel("y [m]"); ax.set_zlabel("z [m]")
        for k, (a, b) in enumerate((("y_m", "z_m"), ("x_m", "y_m"))):
            ax2 = fig.add_subplot(1, 3, k + 2)
            ax2.plot(t[a], t[b], "o-")
            ax2.set_xlabel(a.replace("_m", " [m]")); ax2.set_ylabel(b.replace("_m", " [m]"))
            ax2.set_aspect("equal", adjustable="datalim"); ax2.grid(True)
        fig.suptitle(f"{result.summary['case']}: centres of mass")
        made.append((fig, "shape.png"))
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
        fig.suptitle(f"{result.summary['case']}: support reactions")
        made.append((fig, "reactions.png"))
    for fig, name in made:
        fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".png", dir=out)
        import os
        os.close(fd)
        fig.savefig(tmp, dpi=110)
        plt.close(fig)
        yield tmp, out / name
