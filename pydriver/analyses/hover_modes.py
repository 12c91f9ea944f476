"""The modes a flight run is measured against: those about the hover equilibrium at the
flight's rotor speed and number of bodies (issue 21).

The hover state of a flight deck is the same cable in the same turning hub frame with the blade
held at its mean angles (the constant terms a0 of the flap, lag and pitch series) and no air
stream; its damped modes (Coriolis coupling and joint dampers included, ``modal_analysis``) are
the frequencies the periodic blade motion excites at its harmonics.  They are added to the
flight summary as ``frequencies_hz`` / ``damped_frequencies_hz`` so that a refined run
extrapolates them like every other number.
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.common import rotor_period

#: The transient a march starts with, as a share of the cable's length: the distance from the hover
#: start to the periodic motion (the shipped flight decks: 2 to 11 % of L between their first two
#: revolutions).  Used only to estimate how many revolutions the march needs.
START_TRANSIENT_SHARE = 0.1


def hover_changes(deck) -> dict:
    """The deck changes that make a flight scene its hover state: the blade held at its mean angles
    (the constant terms a0 of the flap, lag and pitch series; no extra lead-lag oscillation) and no
    air stream (the same drag, in the still air the rotor turns in).  Empty for a deck that has
    neither a blade motion nor a stream (its own state is its hover state)."""
    changes = {}
    if "blade" in deck.groups and deck["blade.motion"] == "fourier":
        for key in ("flap_deg", "lag_deg", "pitch_deg"):
            series = deck[f"blade.{key}"]
            mean = [float(series[0])] if series is not None and len(series) else [0.0]
            if series is None or list(np.atleast_1d(series)) != mean:
                changes[f"blade.{key}"] = mean
        if deck["blade.lag_extra_deg"] != 0.0:
            changes["blade.lag_extra_deg"] = 0.0
    if "drag" in deck.groups:
        if deck["drag.forward_speed"] != 0.0:
            changes["drag.forward_speed"] = 0.0
        if np.any(np.asarray(deck["drag.stream_velocity"], float) != 0.0):
            changes["drag.stream_velocity"] = [0.0, 0.0, 0.0]
    return changes


def hover_model(model):
    """The flight deck's hover state as a modal deck (same n, same rotor speed)."""
    return model.with_changes({"case.analysis": "modal", "refinement.levels": 1, **hover_changes(model.deck)})


def hover_modes(model):
    """The modal analysis (a Result) of the flight deck's hover state."""
    from pydriver.analyses.modal import modal_analysis
    return modal_analysis(hover_model(model))


def revolutions_needed(model, hover) -> tuple[float, int | None]:
    """How many revolutions marching needs before two agree to ``periodic_tol``, estimated from
    the hover modes: mode k's transient shrinks by exp(-zeta_k omega_k T) a revolution, from
    START_TRANSIENT_SHARE of the cable's length to periodic_tol; the slowest mode decides, plus
    the two revolutions compared.  Returns (revolutions, the deciding mode's number); infinite for
    an undamped oscillating mode (no periodic state is reached by marching: issue 35, an undamped
    refined flight had run for minutes before failing at its step budget)."""
    s = model.deck.values["solver"]
    period = rotor_period(model)
    f = np.asarray(hover.summary["damped_frequencies_hz"], float)
    zeta = np.asarray(hover.summary["damping_ratios"], float)
    oscillating = f > 0.0
    if not np.any(oscillating):
        return 2.0, None
    decay = zeta[oscillating] * 2.0 * np.pi * f[oscillating] / np.sqrt(np.maximum(1.0 - zeta[oscillating] ** 2,
                                                                                   1e-300)) * period
    shrink = np.log(START_TRANSIENT_SHARE * float(np.sum(model.description["bodies"].lengths)) / float(s["periodic_tol"]))
    with np.errstate(divide="ignore"):
        revs = np.where(decay > 0.0, max(shrink, 0.0) / decay, np.inf)
    k = int(np.argmax(revs))
    return float(revs[k]) + 2.0, int(np.flatnonzero(oscillating)[k]) + 1


def require_periodic_reachable(model, hover) -> None:
    """DeckError before marching when the hover modes say the march cannot end within
    ``max_revolutions`` (:func:`revolutions_needed`)."""
    s = model.deck.values["solver"]
    if s["periodic_method"] != "marching":
        return
    revs, mode = revolutions_needed(model, hover)
    if revs <= s["max_revolutions"]:
        return
    f = hover.summary["damped_frequencies_hz"][mode - 1]
    zeta = hover.summary["damping_ratios"][mode - 1]
    need = "never (it is undamped)" if not np.isfinite(revs) else f"after about {revs:.0f} revolutions"
    model.deck.fail("solver", "max_revolutions",
                    f"the periodic state is reached {need}: hover mode {mode} ({f:.4g} Hz) is damped only "
                    f"zeta = {zeta:.3g}, and marching stops after {s['max_revolutions']} revolutions; add damping "
                    "(&cable damping_time, &springs d_beta), raise max_revolutions, or loosen periodic_tol")


def add_hover_modes(model, result, hover=None) -> None:
    """Put the hover state's modes (:func:`hover_modes`, run here unless given) into the flight
    result."""
    if hover is None:
        hover = hover_modes(model)
    s = hover.summary
    result.summary.update(frequencies_hz=s["frequencies_hz"], damped_frequencies_hz=s["damped_frequencies_hz"],
                          damping_ratios=s["damping_ratios"],
                          modes_about="hover equilibrium at the flight's rotor speed and n (blade at its mean "
                                      "angles, no stream)")
    result.extra["hover_modes"] = hover.extra["modes"]
    # Their shapes in q: the start directions of the Floquet subspace (floquet_subspace.py).
    result.extra["hover_mode_shapes_q"] = hover.extra["mode_shapes_q"]
    result.extra["hover_table"] = hover.table
