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


def hover_model(model):
    """The flight deck's hover state as a modal deck (same n, same rotor speed)."""
    deck = model.deck
    changes = {"case.analysis": "modal", "refinement.levels": 1}
    if "blade" in deck.groups:
        for key in ("flap_deg", "lag_deg", "pitch_deg"):
            series = deck[f"blade.{key}"]
            changes[f"blade.{key}"] = [float(series[0])] if series is not None and len(series) else [0.0]
        changes["blade.lag_extra_deg"] = 0.0
    if "drag" in deck.groups:
        changes["drag.forward_speed"] = 0.0
        changes["drag.stream_velocity"] = [0.0, 0.0, 0.0]
    return model.with_changes(changes)


def add_hover_modes(model, result) -> None:
    """Run the modal analysis of the hover state and put its modes into the flight result."""
    from pydriver.analyses.modal import modal_analysis
    hover = modal_analysis(hover_model(model))
    s = hover.summary
    result.summary.update(frequencies_hz=s["frequencies_hz"], damped_frequencies_hz=s["damped_frequencies_hz"],
                          damping_ratios=s["damping_ratios"],
                          modes_about="hover equilibrium at the flight's rotor speed and n (blade at its mean "
                                      "angles, no stream)")
    result.extra["hover_modes"] = hover.extra["modes"]
    result.extra["hover_table"] = hover.table
