"""A load that is zero changes nothing (issue 35, "a silent wrong answer").

Issue 35 found that a ``&drag`` group on the static UH-60 part-2 deck (no rotor, no stream: drag
on a body at rest in still air is zero) sent the equilibrium to another, unstable one: the
presence of a non-conservative load had switched the static solver to another path.  The class
tested here, over every load kind the component registry declares and every shipped deck:

* a load whose parameters make it vanish everywhere (a pulse of zero force, drag with C_d = 0,
  gravity and a tip force of zero) changes no number, bit for bit;
* a load that vanishes at the state (drag in still air on a static or modal deck: zero at rest)
  changes no number of the equilibrium and its modes, bit for bit;
* a load whose force vanishes at the equilibrium but not its stiffness (an anchor spring hooked
  where its joint sits) leaves the equilibrium where it was, within the Newton tolerance.

A load kind added to :data:`pydriver.components.LOADS` without a zero instance here fails
:func:`test_every_load_kind_has_a_zero_instance`.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import INPUTS
from pydriver.analyses import run as run_analysis
from pydriver.components import LOADS
from pydriver.model import Model

SHIPPED = sorted(p.stem for p in INPUTS.glob("*.nml"))

#: The deck values that make each load kind vanish everywhere, and which decks can take them
#: (a deck that has the load already would change by them, so it is left out).  A kind whose
#: deck schema admits no zero value says why and how it is checked instead.
ZERO_EVERYWHERE = {
    "gravity": {"loads.gravity": [0.0, 0.0, 0.0]},
    "tip_force": {"loads.tip_force": [0.0, 0.0, 0.0]},
    "drag": {"drag.cd": 0.0},
    "pulse": {"loads.pulse_body": 1, "loads.pulse_force": [0.0, 0.0, 0.0], "loads.pulse_start": 0.01,
              "loads.pulse_end": 0.02},
}
#: Kinds the schema keeps from vanishing: the anchor's stiffness must be > 0 (it is checked by its
#: force vanishing at the equilibrium, below); the joint springs are not built when every constant
#: is 0 (``components.LOADS``: present only with a nonzero one) and the rotation springs hold the
#: &cable's EI, GJ > 0.
NOT_ZERO_BY_SCHEMA = {"anchor": "test_anchor_at_its_joint_leaves_the_equilibrium",
                      "joint_springs": "absent when zero", "rotation_springs": "EI, GJ > 0"}


def test_every_load_kind_has_a_zero_instance():
    kinds = {c.kind for c in LOADS}
    assert kinds == set(ZERO_EVERYWHERE) | set(NOT_ZERO_BY_SCHEMA), kinds


def _numbers(result) -> dict:
    """Every number of a result a user sees: the summary's numeric leaves and every column of its
    tables (the equilibrium table, the time series, the modes, the fatigue table)."""
    out = {}

    def walk(prefix, x):
        if isinstance(x, dict):
            for k, v in x.items():
                if k not in ("wall_time_s", "solver", "warnings", "notes") and not k.endswith("wall_time_s"):
                    walk(f"{prefix}.{k}", v)
        elif isinstance(x, (list, tuple)) and x and all(isinstance(v, (int, float)) for v in x):
            out[prefix] = np.asarray(x, float)
        elif isinstance(x, (int, float)) and not isinstance(x, bool):
            out[prefix] = np.asarray([x], float)
    walk("summary", result.summary)
    for name in ("table", "timeseries"):
        for k, v in (getattr(result, name, None) or {}).items():
            if np.asarray(v).dtype.kind in "fi":
                out[f"{name}.{k}"] = np.asarray(v, float)
    for name in ("modes", "fatigue"):
        for k, v in (result.extra.get(name) or {}).items():
            if np.asarray(v).dtype.kind in "fi":
                out[f"{name}.{k}"] = np.asarray(v, float)
    return out


def _differences(a, b) -> list[str]:
    """The numbers of a and b that are not the same bits (keys of one only count too)."""
    na, nb = _numbers(a), _numbers(b)
    keys = sorted(set(na) | set(nb))
    return [k for k in keys if k not in na or k not in nb or not np.array_equal(na[k], nb[k])]


def _model(stem: str, changes: dict | None = None) -> Model:
    model = Model.from_deck(INPUTS / f"{stem}.nml")
    if changes:
        model = model.with_changes(changes)
    # The refined decks at the deck's n only: the class is about the load, not the refinement.
    if model.deck["refinement.levels"] > 1:
        model = model.with_changes({"refinement.levels": 1})
    return model


#: The flight design deck optimises the main job's cable (uh60_part2_forward_flight_cable, which
#: is checked) for 16 s; the design optimiser's own tests run it.
LONG = {"uh60_part2_design_flight"}


def _short(stem: str) -> dict:
    """Deck changes that keep a run short without changing the class checked (none so far)."""
    return {}


def _has(model: Model, kind: str) -> bool:
    return kind in model.description["loads"]


@pytest.mark.parametrize("kind", sorted(ZERO_EVERYWHERE))
def test_a_load_that_vanishes_everywhere_changes_no_number(kind):
    changes = ZERO_EVERYWHERE[kind]
    checked = 0
    for stem in SHIPPED:
        if stem in LONG:
            continue
        base = _model(stem, _short(stem))
        group = next(iter(changes)).split(".")[0]
        if _has(base, kind) or (kind == "drag" and "drag" in base.deck.groups):
            continue
        if kind == "pulse" and base.analysis in ("campbell",):
            continue                                # no time axis: the pulse is refused there
        zeroed = _model(stem, {**_short(stem), **changes})
        assert group in zeroed.deck.groups or kind in ("gravity", "tip_force", "pulse"), stem
        diff = _differences(run_analysis(base), run_analysis(zeroed))
        assert not diff, f"{stem}: a {kind} of zero changed {diff[:5]}"
        checked += 1
    # Every shipped deck but the thesis's gravity-free cantilever has gravity; the rest can take
    # each zero load.
    assert checked >= (1 if kind == "gravity" else 5), f"{kind}: only {checked} decks could take a zero instance"


@pytest.mark.parametrize("stem", [s for s in SHIPPED])
def test_still_air_drag_changes_no_equilibrium(stem):
    """Drag in still air on a deck whose equilibrium is at rest in an inertial frame: zero at the
    equilibrium and along the whole static path, so the equilibrium, its reactions, stability
    and modes are the same bits (the drag's damping enters the damped modes only, and it is zero
    at rest)."""
    base = _model(stem)
    if base.analysis not in ("static", "modal") or base.description["rotor"] is not None \
            or "drag" in base.deck.groups:
        pytest.skip("not an equilibrium at rest in still air")
    still = _model(stem, {"drag.air_density": 1.225})
    assert "drag" in still.description["loads"]
    a, b = run_analysis(base), run_analysis(still)
    keep = [k for k in _differences(a, b) if "damped" not in k and "zeta" not in k and "damping" not in k
            and "growth_rate" not in k]
    assert not keep, f"{stem}: still-air drag changed {keep[:5]}"
    assert b.summary["equilibrium_stability"]["verdict"] == "stable"


def test_the_issue_deck_keeps_its_stable_equilibrium():
    """The case of issue 35 itself: uh60_part2 with &drag air_density = 1.225 gives the reactions
    of the deck without it (F_A = (26.09, -143.29, -11.60) N), not the unstable equilibrium with
    joints 3-7 straight (F_A = (-14.89, 53.88, -14.35) N)."""
    result = run_analysis(_model("uh60_part2", {"drag.air_density": 1.225}))
    f_a = result.summary["reactions"]["A"]["F"]
    assert f_a == pytest.approx([26.09, -143.29, -11.60], abs=0.01)   # the printed digits
    assert result.summary["equilibrium_stability"]["verdict"] == "stable"


def test_anchor_at_its_joint_leaves_the_equilibrium():
    """An anchor spring whose point is where its joint sits at the equilibrium pulls with zero
    force there: the equilibrium stays, within the Newton tolerance (its stiffness changes the
    Newton path, so not bit for bit).  Tolerance: newton_tol 1e-10 Nm over the softest stiffness
    eigenvalue (0.087 Nm/rad) gives ~1e-9 rad; 1e-7 rad leaves two decades for the anchor's own
    stiffness in the path."""
    for stem in ("uh60_part2", "six_link_static", "uh60_part2_modal"):
        base = run_analysis(_model(stem))
        q = base.extra["q"]
        joint = 3
        point = Model.from_deck(INPUTS / f"{stem}.nml").core.shape(q)["joints"][joint - 1]
        anchored = run_analysis(_model(stem, {"anchor.joint": joint, "anchor.point": list(point),
                                              "anchor.stiffness": 500.0}))
        assert np.max(np.abs(anchored.extra["q"] - q)) < 1.0e-7, stem
        assert anchored.summary["reactions"]["A"]["F"] == pytest.approx(base.summary["reactions"]["A"]["F"],
                                                                       abs=1.0e-6)
