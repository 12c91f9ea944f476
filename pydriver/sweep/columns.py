"""The columns of a sweep's table, ``DIR/sweep.csv`` (:mod:`pydriver.sweep.table`), which its
plots (:mod:`pydriver.sweep.plots`) and :func:`pydriver.load_results` read too."""

from __future__ import annotations

SOLVER_KEYS_DYNAMIC = ("steps", "residual_evals", "jacobian_evals", "error_test_failures",
                       "convergence_failures")
SOLVER_KEYS_STATIC = ("newton_iterations", "residual_evals", "jacobian_evals", "line_search_cuts")
REACTION_COLUMNS = [f"{kind}{side}_{c}" for side in "AB" for kind in "FM" for c in "xyz"]
# Columns present in every sweep.csv (blank where a run does not have the quantity, e.g.
# frequencies of a static run or FB_* of an open chain), so the layout depends only on
# the kind of analysis, not on which runs happened to fail.
RESULT_COLUMNS = (["analysis", "wall_time_s", "max_constraint_violation_m"] + REACTION_COLUMNS
                  + ["f1_hz", "f2_hz", "f3_hz", "f1_damped_hz", "zeta1"])
# Optional columns, included when at least one run has them.
DYNAMIC_COLUMNS = ["energy_drift_rel"]
SOLVER_COLUMNS = [f"solver_{k}" for k in dict.fromkeys(SOLVER_KEYS_STATIC + SOLVER_KEYS_DYNAMIC)]
TEXT_COLUMNS = {"id", "analysis", "error"}
