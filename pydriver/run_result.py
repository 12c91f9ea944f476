"""The one result object of a run, whatever the analysis."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pydriver.errors import RunError


@dataclass
class Result:
    """Outcome of one deck run.

    Attributes
    ----------
    summary : dict
        The content of ``summary.json`` (strict JSON: no NaN or Inf).
    table : dict of numpy arrays or None
        Equilibrium table columns (``body, gamma_deg, beta_deg, x_m, y_m, z_m``, ...).
    timeseries : dict of numpy arrays or None
        Time-series columns (``t``, ``x1`` ..., ``gamma1_deg`` ..., reactions, joint loads).
        None when a large run streamed its time series to disk only (see ``files``).
    extra : dict
        Arrays not written to the CSV files (coordinates, energy, mode shapes, ...);
        ``extra["modes"]`` holds the columns of ``modes.csv``.
    files : dict
        Files written by the run, name -> path (filled when the run had an output directory).
    """

    summary: dict
    table: dict | None = None
    timeseries: dict | None = None
    extra: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)

    @property
    def modes(self) -> dict | None:
        """The columns of ``modes.csv`` (modal runs)."""
        return self.extra.get("modes")


def require_finite(result: Result, deck: str) -> None:
    """Refuse a result holding NaN or Inf anywhere it would be written: a non-finite number is
    a failed computation, never an answer."""
    def bad(x) -> bool:
        if isinstance(x, dict):
            return any(bad(v) for v in x.values())
        if isinstance(x, (list, tuple)):
            return any(bad(v) for v in x)
        if isinstance(x, (float, np.floating)):
            return not np.isfinite(x)
        if isinstance(x, np.ndarray) and x.dtype.kind == "f":
            return not np.all(np.isfinite(x))
        return False

    for name in ("summary", "table", "timeseries"):
        if bad(getattr(result, name)):
            raise RunError(f"deck '{deck}': the {name} holds a non-finite number (NaN or Inf); the run is "
                           "refused rather than written")
    if bad(result.extra.get("modes")):
        raise RunError(f"deck '{deck}': the mode table holds a non-finite number")
