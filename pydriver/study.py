"""Parameter studies built on run_deck: frequency against c_y (thesis Figure 5.9), the c_y
where the first frequency meets the flap frequency, and discretisation refinement.

Each study writes modified copies of a deck (namelist keys replaced, nothing else touched)
into a temporary directory and runs them; results come back as numpy arrays.  ``run_study``
writes a study's files as one output of the kind ``study <name>`` (:mod:`pydriver.ownership`).
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np

from pydriver.deckfile import patch_deck
from pydriver.examples import examples_dir
from pydriver.output_columns import header
from pydriver.ownership import study_kind
from pydriver.run import run_deck
from pydriver.run_directory import RunDirectory


def override_deck(src, dst, changes: dict) -> Path:
    """Copy deck ``src`` to ``dst`` with ``changes = {group: {key: value_text}}`` applied
    (f90nml, :func:`pydriver.deckfile.patch_deck`; value texts are namelist syntax, e.g.
    ``"35.0"``, ``"90.0, 10*0.0"``, ``"'modal'"``)."""
    return patch_deck(src, dst, changes)


def _modal(deck, changes, tmp):
    p = override_deck(deck, Path(tmp) / f"d{len(list(Path(tmp).iterdir()))}.nml",
                      {"case": {"analysis": "'modal'"}, **changes})
    return run_deck(p).summary


def frequency_vs_cy(deck, c_values) -> dict:
    """First undamped/damped frequency and damping ratio of a deck for each bending spring c_y."""
    out = {"c_y": np.asarray(c_values, float), "f_undamped_hz": [], "f_damped_hz": [], "zeta": []}
    with tempfile.TemporaryDirectory() as tmp:
        for c in out["c_y"]:
            s = _modal(deck, {"springs": {"c_beta": repr(float(c))}}, tmp)
            out["f_undamped_hz"].append(s["frequencies_hz"][0])
            out["f_damped_hz"].append(s["damped_frequencies_hz"][0])
            out["zeta"].append(s["damping_ratios"][0])
    return {k: np.asarray(v, float) for k, v in out.items()}


def cy_at_frequency(deck, f_target: float, lo: float, hi: float, key="f_damped_hz",
                    tol: float = 1e-4) -> float:
    """c_y where the first frequency equals ``f_target``, by bisection on modal analyses.

    The first frequency rises monotonically with c_y (thesis Figure 5.9); [lo, hi] must
    bracket the target.
    """
    def f(c):
        return frequency_vs_cy(deck, [c])[key][0] - f_target
    f_lo, f_hi = f(lo), f(hi)
    if f_lo * f_hi > 0:
        raise ValueError(f"c_y in [{lo}, {hi}] does not bracket {f_target} Hz")
    while hi - lo > tol * max(1.0, lo):
        mid = 0.5 * (lo + hi)
        f_mid = f(mid)
        if f_mid * f_lo <= 0:
            hi = mid
        else:
            lo, f_lo = mid, f_mid
    return 0.5 * (lo + hi)


def refined_changes(n: int, n0: int, c_beta0: float, c_gamma0: float, d_beta0: float,
                    d_gamma0: float, first_angles, bend0_deg: float, twist2_deg: float) -> dict:
    """Deck changes that refine a cable from n0 to n bodies at equal bending stiffness.

    Eq. 5.2: c_y = c_yj / j, so the per-joint spring scales with n/n0 (EI = c l); the joint
    dampers scale the same way so the cable's damping per length stays.  The start shape
    keeps the total bend: (n - 1) joints of bend0 (n0 - 1)/(n - 1) each.
    """
    r = n / n0
    bend = bend0_deg * (n0 - 1) / (n - 1)
    return {"chain": {"n_bodies": str(n)},
            "shape": {"gamma_deg": f"{first_angles[0]}, {twist2_deg}, {n - 2}*0.0",
                      "beta_deg": f"{first_angles[1]}, {n - 1}*{bend}"},
            "springs": {"c_beta": repr(c_beta0 * r), "c_gamma": repr(c_gamma0 * r),
                        "d_beta": repr(d_beta0 * r), "d_gamma": repr(d_gamma0 * r)}}


def observed_order(h, values) -> float:
    """Observed convergence order from the three finest of a sequence halving h."""
    f1, f2, f3 = values[-3:]
    return float(np.log(abs((f1 - f2) / (f2 - f3))) / np.log(h[-3] / h[-2]))


def run_study(name: str, out: Path, inputs: Path | None = None) -> str:
    """Run a named study and write its CSV/JSON/PNG files into ``out``; returns a summary line.

    ``out`` is an output of the kind ``study <name>`` (:mod:`pydriver.ownership`): a new or
    empty directory or one earlier output of the same study, written whole through a
    temporary directory (:class:`pydriver.run_directory.RunDirectory`) and refused, before
    anything is computed, when it holds anything else.  The UH-60 decks come from the example
    decks (a source checkout's inputs/ or the installed package's data) unless ``inputs``
    says otherwise.

    Raises
    ------
    ValueError
        ``name`` is not a study.
    OutputError
        ``out`` must not be written (a user's files, another kind of output, a link, ...).
    FileNotFoundError
        The UH-60 decks are not in ``inputs``.
    """
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r}; the studies are: {', '.join(STUDIES)}")
    inputs = Path(inputs) if inputs is not None else examples_dir()
    if not (inputs / "uh60_part2_modal.nml").is_file():
        raise FileNotFoundError(f"the UH-60 decks are not in {inputs}")
    out = Path(out)
    if name == "design":
        from pydriver.design_study import design_study, study_lines
        study = design_study(inputs / "uh60_part2_design_flight.nml", out)
        return "\n".join(study_lines(study) + [f"wrote {out}/ (design_study.json, summary.json, optimum.nml, "
                                               "design_history.csv, resonance.csv, report.html)"])
    with RunDirectory(out, deck=name, kind=study_kind(name)) as run_dir:
        line = STUDIES[name](inputs, run_dir.tmp)
        run_dir.commit()
    return f"{line}; wrote {out}"


def _shapes(inputs: Path, tmp: Path) -> str:
    from pydriver.plots import plot_shapes
    for part in (1, 2):
        tables = {label: run_deck(inputs / f"uh60_part{part}{suffix}.nml").table
                  for label, suffix in (("rest", ""), ("hover 260 rpm", "_hover"))}
        plot_shapes(tables, tmp / f"uh60_part{part}_rest_vs_hover.png",
                    f"UH-60 cable part {part}: rest vs hover (thesis Figures 5.6/5.12)")
    return "rest vs hover: uh60_part1_rest_vs_hover.png, uh60_part2_rest_vs_hover.png"


def _cy_sweep(inputs: Path, tmp: Path) -> str:
    from pydriver.plots import plot_frequency_vs_cy
    deck = inputs / "uh60_part2_modal.nml"
    c = np.r_[1.0, np.arange(2.0, 71.0, 2.0)]
    res = frequency_vs_cy(deck, c)
    c_cross = cy_at_frequency(deck, 4.33, 0.5, 5.0)
    # The deck's word for c_y, each with its unit (pydriver/output_columns.py, as every CSV of a run).
    rows = [",".join(header("frequency_vs_cy.csv", ["c_y_Nm_per_rad", "f_undamped_hz", "f_damped_hz", "zeta"]))]
    # repr(float(x)): the shortest text that reads back exactly (repr of a numpy 2 scalar
    # is "np.float64(1.0)", which no CSV reader takes).
    rows += [",".join(repr(float(x)) for x in row) for row in
             zip(res["c_y"], res["f_undamped_hz"], res["f_damped_hz"], res["zeta"])]
    (tmp / "frequency_vs_cy.csv").write_text("\n".join(rows) + "\n")
    (tmp / "flap_crossing.json").write_text(json.dumps(
        {"f_flap_hz": 4.33, "c_y_Nm_per_rad": c_cross,
         "thesis_reading_Nm_per_rad": 8.0}, indent=2) + "\n")
    plot_frequency_vs_cy(res, tmp / "frequency_vs_cy.png", 4.33, c_cross)
    return f"first frequency meets 4.33 Hz at &springs c_beta = {c_cross:.3f} Nm/rad (the thesis's c_y)"


def _refine(inputs: Path, tmp: Path) -> str:
    deck = inputs / "uh60_part2_modal.nml"
    ns = [11, 22, 44, 88]
    f_u, f_d = [], []
    with tempfile.TemporaryDirectory() as decks:
        for n in ns:
            p = override_deck(deck, Path(decks) / f"n{n}.nml",
                              refined_changes(n, 11, 35.531, 1e-4, 0.05, 1e-4, (90.0, 70.0), 12.0, 90.0))
            s = run_deck(p).summary
            f_u.append(s["frequencies_hz"][0])
            f_d.append(s["damped_frequencies_hz"][0])
    order = observed_order(1.0 / np.array(ns), f_u)
    (tmp / "refinement.json").write_text(json.dumps(
        {"n_bodies": ns, "f_undamped_hz": f_u, "f_damped_hz": f_d,
         "observed_order_undamped": order}, indent=2) + "\n")
    return f"n = {ns}: f1 = {np.round(f_u, 3)} Hz, observed order {order:.2f}"


#: The studies that write through run_study's temporary directory (design writes its own).
STUDIES = {"shapes": _shapes, "cy-sweep": _cy_sweep, "refine": _refine, "design": None}
