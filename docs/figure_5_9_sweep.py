# %% [markdown]
# # Thesis Figure 5.9 from a parameter sweep
#
# First natural frequency of the UH-60 de-icing cable, part 2, against the bending spring
# c_y (thesis Figure 5.9), with the main-rotor flap frequency 4.33 Hz.  Each point is the
# modal analysis of `inputs/uh60_part2_modal.nml` (equilibrium by Newton, then the
# linearised damped eigenproblem) with `&springs c_beta` changed.
#
# Run it as a script from the project root (`.venv/bin/python docs/figure_5_9_sweep.py`) or
# cell by cell (`# %%`) in VS Code / Jupyter.  The sweeps run through the command line, as
# batch runs do on a cluster, and this file only post-processes them with
# `pydriver.load_results`; rerunning is instant because a finished sweep is resumed, not
# recomputed.  Output: `results/figure_5_9_sweep/figure_5_9.png`.
#
# docs/model.md ("First frequency against c_y") explains why the crossing with the flap
# frequency comes out at c_y ≈ 1.0 Nm/rad rather than the ≈ 8 Nm/rad read off the thesis's
# figure.

# %%
import subprocess
import sys
from pathlib import Path

import numpy as np

import pydriver

ROOT = Path(__file__).resolve().parents[1] if "__file__" in globals() else Path.cwd()
BASE = ROOT / "inputs" / "uh60_part2_modal.nml"
OUT = ROOT / "results" / "figure_5_9_sweep"
F_FLAP = 4.33          # main-rotor flap frequency [Hz], thesis section 5.4


def sweep(out: Path, *sets: str) -> None:
    """`python -m pydriver sweep BASE --set ... --out out` (all cores, resumable)."""
    cmd = [sys.executable, "-m", "pydriver", "sweep", str(BASE), "--out", str(out), "--no-plots"]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True)


# %% [markdown]
# ## The sweep: 24 values of c_y from 1 to 70 Nm/rad
# `1:70:24` is 24 evenly spaced points including both ends (1, 4, 7, ..., 70).

# %%
sweep(OUT / "cy", "springs.c_beta=1:70:24")
res = pydriver.load_results(OUT / "cy")
assert not res.missing and not any(res.table["error"]), "some runs failed: see sweep.csv"
c_y = res.table["springs.c_beta"]
f_damped = res.table["f1_damped_hz"]
f_undamped = res.table["f1_hz"]
for c, f in zip(c_y[::4], f_damped[::4]):
    print(f"c_y = {c:5.1f} Nm/rad: first damped frequency {f:6.2f} Hz")

# %% [markdown]
# The mode shape of any point is at hand, e.g. the first mode at the deck's own
# c_y ≈ 35.5 Nm/rad neighbour (run 0011, c_y = 34):

# %%
run = res.runs["0011"]
print(run.params, "f1 =", run.modes["f_damped_hz"][0], "Hz, zeta1 =", run.modes["zeta"][0])

# %% [markdown]
# ## Where the first frequency meets the flap frequency
# At c_y = 1 the first damped frequency is already just above 4.33 Hz, so a second, finer
# sweep (13 log-spaced points over 0.5 ... 2 Nm/rad) brackets the crossing; the frequency
# rises monotonically with c_y, so interpolating log c_y against f locates it.

# %%
sweep(OUT / "crossing", "springs.c_beta=log:0.5:2:13")
fine = pydriver.load_results(OUT / "crossing")
c_cross = float(np.exp(np.interp(F_FLAP, fine.table["f1_damped_hz"],
                                 np.log(fine.table["springs.c_beta"]))))
print(f"first damped frequency = {F_FLAP} Hz at c_y = {c_cross:.3f} Nm/rad")

# %% [markdown]
# ## Figure 5.9

# %%
from pydriver.plots import plot_frequency_vs_cy  # noqa: E402  (cell-local import)

png = OUT / "figure_5_9.png"
plot_frequency_vs_cy({"c_y": c_y, "f_damped_hz": f_damped, "f_undamped_hz": f_undamped},
                     png, F_FLAP, c_cross)
print(f"wrote {png}")
