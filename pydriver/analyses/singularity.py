"""How close the Cardan joints (``&chain joint = 'xy'`` or ``'xyz'``) came to their coordinate
singularity, for the summary and its warnings.

A Cardan joint turns by phi about the parent's x axis, then by theta about the new y axis
(docs/model.md, "Cardan bending joint"; coordinates (phi, theta[, psi]) per free joint,
src_fortran/joint.f90).  At theta = +-90 deg the child's axis lies along the parent's x axis,
the phi axis, so phi turns the child about its own axis and the joint has lost a bending
direction: a bending rate omega across the joint needs phi-dot ~ omega / |cos theta|.  The
distance from the singularity is |cos theta| = sin(margin), margin the angle between theta and
+-90 deg; the core's failure hint uses the same measure (dae_integrator.f90,
``singularity_margin``).

The closest approach is taken over the output samples.  Where cos theta changes sign between
two samples the joint passed through theta = +-90 deg itself (theta is continuous), and the
closest approach is 0 at the linearly interpolated instant.
"""

from __future__ import annotations

import numpy as np

#: Warn when a joint came within this angle of theta = +-90 deg.  The core's hint for the zy
#: joint's singularity uses 2 deg as "near" too; here the phi rate is then amplified by more
#: than 1/sin(2 deg) = 29.  Measured on free xy pendulums (1 and 2 bodies of 0.5 m, released 1
#: and 30 deg above the horizontal in planes 1e-5 to 20 deg off the singular direction, 112
#: runs; tip position at rtol 1e-8 against rtol 1e-12 over 0.6 s): errors up to 6e-7 L with
#: the closest approach above 3 deg, up to 9e-7 L between 0.3 and 3 deg, up to 9e-6 L below
#: 0.3 deg, with twice the steps.  Chains with clamps are stiffer (the undamped six-link xy
#: swing stops at 6 deg, dae_integrator.f90), hence the margin above 0.3 deg.
WARN_DEG = 2.0


def theta_indices(model) -> tuple[np.ndarray, np.ndarray]:
    """0-based indices in q of every free Cardan joint's theta, and the joints' numbers (1-based);
    empty for the thesis's zy joint (its singularity, beta = 0, is another matter:
    :func:`pydriver.analyses.common.straight_zy_warnings`)."""
    if model.deck["chain.joint"] not in ("xy", "xyz"):
        return np.zeros(0, int), np.zeros(0, int)
    first = np.asarray(model.description["first_coord"], int)       # 1-based, 0 = locked joint
    joints = np.nonzero(first > 0)[0]
    # (phi, theta[, psi]) from the 1-based first_coord on: theta's 0-based index is first_coord.
    return first[joints], joints + 1


class ClosestApproach:
    """The smallest |cos theta| over the Cardan joints and the samples fed to :meth:`update`.

    Parameters
    ----------
    model : pydriver.model.Model
    """

    def __init__(self, model):
        self.index, self.joints = theta_indices(model)
        self.min_cos = np.inf
        self.joint = 0
        self.t = np.nan
        self.passed_through = False
        self._last = None               # (t, cos theta) of the last sample seen

    @property
    def active(self) -> bool:
        """Whether the model has Cardan joints to watch."""
        return self.index.size > 0

    def update(self, t, q) -> None:
        """Take samples at times t (nt) with states q (nq, nt), in time order across calls."""
        if not self.active:
            return
        t = np.atleast_1d(np.asarray(t, float))
        c = np.cos(np.asarray(q, float).reshape(-1, len(t))[self.index, :])      # (joints, nt)
        if self._last is not None:
            t = np.concatenate([[self._last[0]], t])
            c = np.column_stack([self._last[1], c])
        a = np.abs(c)
        j, k = np.unravel_index(np.argmin(a), a.shape)
        if a[j, k] < self.min_cos:
            self.min_cos, self.joint, self.t = float(a[j, k]), int(self.joints[j]), float(t[k])
        # A sign change of cos theta between neighbouring samples: theta = +-90 deg in between.
        flips = np.nonzero(c[:, :-1] * c[:, 1:] < 0.0)
        if flips[0].size and self.min_cos > 0.0:
            first = int(np.argmin(flips[1]))                  # the earliest passage
            j, k = int(flips[0][first]), int(flips[1][first])
            w = c[j, k] / (c[j, k] - c[j, k + 1])
            self.min_cos, self.joint, self.t = 0.0, int(self.joints[j]), float(t[k] + w * (t[k + 1] - t[k]))
            self.passed_through = True
        self._last = (float(t[-1]), c[:, -1].copy())

    def summary(self) -> dict | None:
        """The summary entry (None without Cardan joints): ``min_abs_cos_theta``, ``margin_deg``
        (angle between theta and +-90 deg), ``joint``, ``t_s``, ``passed_through``,
        ``warn_below_deg``."""
        if not self.active or not np.isfinite(self.min_cos):
            return None
        return {"min_abs_cos_theta": self.min_cos, "margin_deg": float(np.degrees(np.arcsin(min(self.min_cos, 1.0)))),
                "joint": self.joint, "t_s": self.t, "passed_through": self.passed_through,
                "warn_below_deg": WARN_DEG}

    def warnings(self, when: str | None = None) -> list[str]:
        """The warning, if the closest approach was within WARN_DEG; ``when`` replaces the
        "at t = ..." text (e.g. "in the equilibrium")."""
        s = self.summary()
        if s is None or s["margin_deg"] >= WARN_DEG:
            return []
        where = when or f"at t = {s['t_s']:.4g} s"
        if s["passed_through"]:
            what = f"joint {s['joint']} passed through the Cardan singularity (theta = +-90 deg) {where}"
        else:
            what = (f"joint {s['joint']} came within {s['margin_deg']:.2g} deg of the Cardan singularity "
                    f"(theta = +-90 deg, |cos theta| = {s['min_abs_cos_theta']:.2g}) {where}")
        if s["joint"] == 1:
            cure = ("there the cable points along the x axis of clamp A's frame: turn that frame "
                    "(&clamp_a gamma_deg, beta_deg) so that the cable does not point along it")
        else:
            cure = (f"there bodies {s['joint'] - 1} and {s['joint']} meet at a right angle: use more bodies "
                    "(a smaller kink per joint)")
        return [f"{what}; results near it can lose accuracy, as the joint's phi rate grows like "
                f"1/|cos theta| and the integrator's steps shrink (warned below {WARN_DEG:g} deg); {cure}"]


def equilibrium_report(model, q) -> tuple[dict | None, list[str]]:
    """The closest approach of one state (a static equilibrium): its summary entry and warnings.

    For the static and modal analyses (``summary["cardan_singularity"]``): a modal analysis
    linearises in the joint coordinates, which lose a direction at the singularity.
    """
    tracker = ClosestApproach(model)
    tracker.update([0.0], np.asarray(q, float)[:, None])
    s = tracker.summary()
    if s is not None:
        del s["t_s"]
    return s, tracker.warnings(when="in the equilibrium")
