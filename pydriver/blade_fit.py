"""Blade motion from data: the blade's flap, lead-lag and pitch angles against its azimuth, as
a comprehensive rotor code or a flight test delivers them, fitted as the Fourier series of
``&blade`` (``flap_deg = a0, a1c, a1s, a2c, a2s, ...``; docs/model.md, "Moving supports").

The file is a CSV table (:mod:`pydriver.data_tables`) with the columns

* ``azimuth_deg``: the blade azimuth psi_b [deg], 0 downstream (the tail), in the sense of
  rotation, as the deck's series use it; any values, each azimuth once (modulo 360);
* any of ``flap_deg`` (flap up positive), ``lag_deg`` (lag, against the rotation, positive) and
  ``pitch_deg`` (nose up positive) [deg], relative to the installed pose of the deck (all
  angles zero); an angle without a column keeps the deck's own series.

Each angle is fitted by linear least squares (``numpy.linalg.lstsq``) on the basis 1, cos psi,
sin psi, ..., cos h psi, sin h psi (h harmonics, ``&spectrum blade_harmonics``), which needs at
least 2 h + 1 distinct azimuths.  The fit's residual at the table's azimuths is reported, its
root mean square and its largest magnitude per angle, and a fit whose largest residual exceeds
the deck's tolerance is refused by the caller: the series would not be the data.  A least-
squares fit rather than a spline because the deck's motion is a Fourier series in the azimuth
(periodic, smooth, with the derivatives the core needs in closed form), and the harmonics above
h, which the fit leaves out, are what the residual shows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.data_tables import read_columns

#: The angles a blade table may give, by their column names ``<angle>_deg``.
ANGLES = ("flap", "lag", "pitch")


@dataclass(frozen=True)
class AngleFit:
    """One angle fitted against the azimuth.

    Attributes
    ----------
    coefficients : tuple of float
        a0, a1c, a1s, ..., ahc, ahs [deg], the ``&blade <angle>_deg`` series.
    rms_deg : float
        Root mean square of the residual over the table's azimuths [deg].
    max_deg : float
        Largest residual magnitude [deg].
    max_at_deg : float
        The azimuth of the largest residual [deg].
    """

    coefficients: tuple
    rms_deg: float
    max_deg: float
    max_at_deg: float


def design_matrix(azimuth_deg, harmonics: int) -> np.ndarray:
    """The basis 1, cos psi, sin psi, ..., cos h psi, sin h psi at the azimuths (rows)."""
    psi = np.radians(np.asarray(azimuth_deg, dtype=float))
    columns = [np.ones_like(psi)]
    for k in range(1, harmonics + 1):
        columns += [np.cos(k * psi), np.sin(k * psi)]
    return np.column_stack(columns)


def fit_angle(azimuth_deg, angle_deg, harmonics: int) -> AngleFit:
    """Least-squares Fourier series of one angle against the azimuth.

    Parameters
    ----------
    azimuth_deg, angle_deg : array_like
        The table's azimuths and the angle there [deg].
    harmonics : int
        Highest harmonic h >= 1 of the series.

    Returns
    -------
    AngleFit

    Raises
    ------
    ValueError
        Fewer distinct azimuths (modulo 360 deg) than the 2 h + 1 coefficients, or azimuths that
        do not determine them (the basis loses rank).
    """
    psi = np.asarray(azimuth_deg, dtype=float)
    theta = np.asarray(angle_deg, dtype=float)
    wrapped = np.round(np.mod(psi, 360.0), 9)
    if np.unique(wrapped).size != wrapped.size:
        raise ValueError("an azimuth appears twice (modulo 360 deg): give each azimuth once")
    n_coefficients = 2 * harmonics + 1
    if psi.size < n_coefficients:
        raise ValueError(f"{psi.size} azimuths cannot determine {harmonics} harmonics ({n_coefficients} "
                         "coefficients): give more azimuths or fewer harmonics (&spectrum blade_harmonics)")
    basis = design_matrix(psi, harmonics)
    coefficients, _, rank, _ = np.linalg.lstsq(basis, theta, rcond=None)
    if rank < n_coefficients:
        raise ValueError(f"the azimuths do not determine {harmonics} harmonics (the fit has rank {rank} of "
                         f"{n_coefficients}): spread the azimuths over the revolution")
    residual = theta - basis @ coefficients
    k = int(np.argmax(np.abs(residual)))
    return AngleFit(coefficients=tuple(float(c) for c in coefficients),
                    rms_deg=float(np.sqrt(np.mean(residual ** 2))), max_deg=float(abs(residual[k])),
                    max_at_deg=float(psi[k]))


def fit_blade_file(path, harmonics: int) -> dict[str, AngleFit]:
    """The angles of a blade table fitted as Fourier series (module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    harmonics : int
        Highest harmonic of the series.

    Returns
    -------
    dict
        Angle name (``flap``, ``lag``, ``pitch``) -> :class:`AngleFit`, for each angle the file
        gives.

    Raises
    ------
    ValueError
        The file (:func:`pydriver.data_tables.read_columns`), no angle column, or a fit that
        the azimuths cannot make (:func:`fit_angle`), naming the file.
    """
    columns = read_columns(path, ("azimuth_deg",), tuple(f"{a}_deg" for a in ANGLES), min_rows=1)
    given = [a for a in ANGLES if f"{a}_deg" in columns]
    if not given:
        raise ValueError(f"{path}: no angle column: give any of flap_deg, lag_deg, pitch_deg beside azimuth_deg")
    try:
        return {a: fit_angle(columns["azimuth_deg"], columns[f"{a}_deg"], harmonics) for a in given}
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None
