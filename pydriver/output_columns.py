"""Every column of every output file: its name, unit and meaning, in one table.

The CSV headers carry the unit of each column in brackets, ``FA_x [N]`` (dimensionless
columns ``[-]``), as OpenFAST's output files carry a units row; :func:`header` writes them and
:func:`bare_name` reads them back, so ``load_results`` and every reader keyed by the old names
(``FA_x``) keep working.  ``docs/outputs.md`` is generated from this table
(``python -m pydriver.output_columns``; a test checks it is current and that every column the
shipped decks write has a row here).

Patterns: ``{j}`` is a joint or body number, ``{k}`` a mode number, ``{n}`` a number of bodies;
``{c}`` one of x, y, z.
"""

from __future__ import annotations

import difflib
import re
import sys
from dataclasses import dataclass

from pydriver.reference_output import write_generated


@dataclass(frozen=True)
class Column:
    """One column pattern of an output file."""

    files: tuple          #: the files it appears in
    pattern: str          #: the name, with {j}, {k}, {n}, {c} placeholders
    unit: str             #: SI unit ('-' dimensionless); '*' = given per row or by the deck
    meaning: str


TS = ("timeseries.csv", "timeseries.h5")
FAT = ("fatigue.csv",)
SWEEP = ("sweep.csv",)
LOADS = ("timeseries.csv", "timeseries.h5", "table.csv")

COLUMNS = [
    # -- time series ---------------------------------------------------------------------------
    Column(TS, "t", "s", "time"),
    Column(TS, "psi_deg", "deg", "rotor angle turned since t = 0 (hub frame runs)"),
    Column(TS, "azimuth_deg", "deg", "blade azimuth, 0 = downstream, in the sense of rotation"),
    Column(TS, "{c}{j}", "m", "centre of mass of body {j}, {c} coordinate (deck frame; hub frame when the rotor turns)"),
    Column(TS, "tip_{c}", "m", "end point of the last body, {c} coordinate"),
    Column(TS + SWEEP, "F{s}_{c}", "N", "force support {s} exerts on the chain, {c} component"),
    Column(TS + SWEEP, "M{s}_{c}", "Nm", "moment support {s} exerts on the chain about its clamp point, {c} component"),
    Column(TS, "F{s}_on_support_{c}", "N",
           "force the cable puts on support {s} (what the clamp carries: -F{s}_{c}), {c} component"),
    Column(TS, "M{s}_on_support_{c}", "Nm",
           "moment the cable puts on support {s} about its clamp point (-M{s}_{c}), {c} component"),
    Column(TS, "gamma{j}_deg", "deg", "thesis angle gamma of body {j} (wrapped to +-180)"),
    Column(TS, "beta{j}_deg", "deg", "thesis angle beta of body {j} (wrapped to +-180)"),
    Column(TS, "E_kin_J", "J", "kinetic energy"),
    Column(TS, "E_pot_J", "J", "potential energy (gravity and springs)"),
    Column(TS, "g_max_m", "m", "largest constraint violation of clamp B"),
    Column(LOADS, "axial{j}_N", "N", "axial force joint {j} carries (tension positive)"),
    Column(LOADS, "shear{j}_N", "N", "shear force magnitude at joint {j}"),
    Column(LOADS, "bending{j}_Nm", "Nm", "bending moment magnitude at joint {j}"),
    Column(LOADS, "torsion{j}_Nm", "Nm", "torsion moment at joint {j}"),
    Column(TS, "moment_{a}{j}_Nm", "Nm", "bending moment at joint {j} about the joint's local {a} axis"),
    Column(LOADS, "curvature{j}_1pm", "1/m", "curvature magnitude at joint {j} (bending moment / EI)"),
    Column(TS, "kappa_{a}{j}_1pm", "1/m", "curvature at joint {j} about the joint's local {a} axis"),
    Column(LOADS, "strain{j}", "-", "largest jacket surface strain at joint {j} (curvature x radius)"),
    Column(TS, "{coord}{j}_coord_deg", "deg", "joint coordinate {coord} of joint {j}, the angle the springs act "
                                             "on (not wrapped); the coordinates are gamma, beta (zy), cardan_x, "
                                             "cardan_y (xy) and twist (xyz)"),
    Column(TS, "{coord}{j}_rate_degps", "deg/s", "rate of joint coordinate {coord} of joint {j}"),
    # -- equilibrium table -----------------------------------------------------------------------
    Column(("table.csv",), "body", "-", "body number, from clamp A"),
    Column(("table.csv",), "gamma_deg", "deg", "thesis angle gamma of the body"),
    Column(("table.csv",), "beta_deg", "deg", "thesis angle beta of the body"),
    Column(("table.csv",), "{c}_m", "m", "centre of mass of the body"),
    Column(("table.csv",), "joint_{c}_m", "m", "joint point where the body starts"),
    Column(("table.csv",), "axial_N", "N", "axial force the body's joint carries (tension positive)"),
    Column(("table.csv",), "shear_N", "N", "shear force at the body's joint"),
    Column(("table.csv",), "bending_Nm", "Nm", "bending moment at the body's joint"),
    Column(("table.csv",), "torsion_Nm", "Nm", "torsion moment at the body's joint"),
    Column(("table.csv",), "curvature_1pm", "1/m", "curvature at the body's joint"),
    Column(("table.csv",), "strain", "-", "jacket surface strain at the body's joint"),
    # -- modes -------------------------------------------------------------------------------------
    Column(("modes.csv",), "mode", "-", "mode number, by undamped frequency"),
    Column(("modes.csv",), "f_undamped_hz", "Hz", "undamped natural frequency"),
    Column(("modes.csv",), "f_damped_hz", "Hz", "damped frequency (0: overdamped)"),
    Column(("modes.csv",), "zeta", "-", "damping ratio"),
    Column(("modes.csv",), "d{c}{j}", "-", "displacement of the centre of mass of body {j} in the mode, {c} component (the largest component is 1)"),
    # -- Campbell ------------------------------------------------------------------------------------
    Column(("campbell.csv", "campbell_crossings.csv"), "rpm", "rpm", "rotor speed"),
    Column(("campbell.csv", "campbell_crossings.csv"), "mode", "-", "tracked mode"),
    Column(("campbell.csv",), "f_hz", "Hz", "damped frequency of the mode at that speed"),
    Column(("campbell.csv",), "zeta", "-", "damping ratio"),
    Column(("campbell.csv",), "mac", "-", "modal assurance criterion against the previous speed"),
    Column(("campbell.csv", "campbell_crossings.csv"), "f_extrapolated_hz", "Hz",
           "Richardson value of the frequency (&refinement; blank where a level has no such mode)"),
    Column(("campbell.csv", "campbell_crossings.csv"), "f_error_hz", "Hz", "its error estimate"),
    Column(("campbell.csv", "campbell_crossings.csv"), "f_order", "-", "its observed order of convergence"),
    Column(("campbell_crossings.csv",), "rpm_n{n}", "rpm", "the crossing speed at n bodies (&refinement)"),
    Column(("campbell_crossings.csv",), "rpm_extrapolated", "rpm", "Richardson value of the crossing speed"),
    Column(("campbell_crossings.csv",), "rpm_error", "rpm", "its error estimate"),
    Column(("campbell_crossings.csv",), "rpm_order", "-", "its observed order of convergence"),
    Column(("campbell_crossings.csv", "resonance.csv"), "harmonic", "-", "rotor harmonic k (k/rev)"),
    Column(("campbell_crossings.csv", "resonance.csv"), "frequency_hz", "Hz", "damped frequency of the mode"),
    # -- Floquet stability ---------------------------------------------------------------------------
    Column(("floquet.csv",), "mode", "-", "Floquet mode (a multiplier; complex pairs listed once)"),
    Column(("floquet.csv",), "multiplier_re", "-", "real part of the Floquet multiplier rho"),
    Column(("floquet.csv",), "multiplier_im", "-", "imaginary part of rho"),
    Column(("floquet.csv",), "multiplier_abs", "-", "|rho|: above 1 the periodic motion is unstable"),
    Column(("floquet.csv",), "exponent_re_per_s", "1/s", "real part of the characteristic exponent ln(rho)/T"),
    Column(("floquet.csv",), "exponent_im_per_s", "rad/s", "imaginary part (principal branch)"),
    Column(("floquet.csv",), "frequency_hz", "Hz", "frequency, the multiple of 1/rev resolved by the hover mode"),
    Column(("floquet.csv",), "hover_frequency_hz", "Hz", "the hover mode that resolved it (blank: none)"),
    Column(("floquet.csv",), "damping_ratio", "-", "-Re(eta)/|eta|"),
    Column(("floquet.csv",), "resolved", "-", "1: |rho| above round-off (0.1 rtol |rho|max; a refined run's subspace: and a converged Ritz pair); 0: not matched to a hover mode"),
    Column(("floquet.csv",), "n_bodies", "-", "a refined run: the level's number of bodies (the finest; every level's verdict in summary.json floquet.levels)"),
    # -- resonance margins -----------------------------------------------------------------------------
    Column(("resonance.csv",), "mode", "-", "mode number"),
    Column(("resonance.csv",), "operating_rpm", "rpm", "operating speed the margin is taken at"),
    Column(("resonance.csv",), "error_hz", "Hz", "error bar of the frequency (Richardson; refined runs)"),
    Column(("resonance.csv",), "harmonic_hz", "Hz", "frequency of the nearest harmonic k/rev"),
    Column(("resonance.csv",), "margin_percent", "%", "|f - k/rev| / (k/rev)"),
    Column(("resonance.csv",), "worst_margin_percent", "%", "the margin narrowed by the error bar"),
    Column(("resonance.csv",), "within_margin", "-", "1 when below &resonance margin_percent"),
    # -- fatigue -----------------------------------------------------------------------------------------
    Column(FAT, "joint", "-", "joint number, from clamp A"),
    Column(FAT, "arc_length_m", "m", "arc length of the joint from clamp A"),
    Column(FAT, "angle_deg", "deg", "where on the jacket the damage is largest: the angle around the cable, from the "
                                     "axis e1 of the body after the joint"),
    Column(FAT, "damage_per_hour", "1/h", "Miner damage per flight hour at that point"),
    Column(FAT, "life_hours", "h", "1 / damage per hour (blank: no damage)"),
    Column(FAT, "n_cycles", "-", "rainflow cycles per record (half cycles count 1/2)"),
    Column(FAT, "del_amplitude", "*", "damage-equivalent amplitude (unit of &fatigue sn_quantity)"),
    Column(FAT, "{q}_{s}", "*", "statistic s (min, max, mean, amplitude) of load q over the record"),
    # -- fatigue at every jacket point (a usage spectrum's regime record) -----------------------------
    Column(("fatigue_points.csv",), "n_bodies", "-", "the refinement level: its number of bodies"),
    Column(("fatigue_points.csv",), "joint", "-", "joint number, from clamp A"),
    Column(("fatigue_points.csv",), "angle_deg", "deg", "the point's angle around the jacket from the child body's e1"),
    Column(("fatigue_points.csv",), "damage_per_record", "-", "Miner damage of the record (one revolution of a "
                                                               "flight, the whole run-up)"),
    Column(("fatigue_points.csv",), "closed_damage_per_record", "-",
           "the damage of the record's closed (full) cycles alone (a flight: all of them)"),
    Column(("fatigue_points.csv",), "minimum", "*", "smallest value of the point's history (unit of &fatigue "
                                                    "sn_quantity)"),
    Column(("fatigue_points.csv",), "maximum", "*", "largest value of the point's history"),
    Column(("fatigue_points.csv",), "first", "*", "first value (the run-up: the rest state, rotor stopped)"),
    Column(("fatigue_points.csv",), "records_per_hour", "1/h", "records per flight hour (a flight: revolutions "
                                                               "per hour)"),
    # -- usage spectrum (analysis = 'spectrum') -----------------------------------------------------------
    Column(("spectrum.csv",), "regime", "-", "the regime (&spectrum regimes), then 'ground-air-ground' (one cycle "
                                             "per flight) and 'start-stops' (the rotor's run-ups and run-downs)"),
    Column(("spectrum.csv",), "time_share", "-", "the regime's share of the flight time (blank: not a regime)"),
    Column(("spectrum.csv",), "damage_per_hour_in_regime", "1/h",
           "Miner damage per hour flown in the regime, at the spectrum's worst point"),
    Column(("spectrum.csv",), "damage_per_flight_hour", "1/h",
           "its damage per flight hour of the spectrum there (time share x damage per hour in regime)"),
    Column(("spectrum.csv",), "damage_share", "-", "its share of the spectrum's damage there"),
    Column(("spectrum.csv",), "life_alone_hours", "h", "the life if only this were flown: 1 / its largest damage "
                                                       "per hour over the cable (blank: no damage)"),
    # -- design sensitivities ------------------------------------------------------------------------
    Column(("sensitivities.csv",), "output", "-",
           "the output differentiated: a reaction FA_x ... MB_z and a joint load axial{j}_N, shear{j}_N, "
           "bending{j}_Nm, torsion{j}_Nm (static runs); an undamped frequency f{k}_hz and a damped frequency "
           "fd{k}_hz (modal runs: modes 1 ... 6); over the "
           "periodic revolution (flight runs) a reaction's extreme FA_x_max ... MB_z_min, a joint load's peak "
           "|value| and amplitude {q}{j}_peak, {q}{j}_amplitude (q: bending, axial, torsion, strain) and, with "
           "&fatigue, damage_per_hour{j}, del_amplitude{j} and del_FA_x ... del_MB_z"),
    Column(("sensitivities.csv",), "parameter", "-", "the &design parameter, group.key or group.key(i)"),
    Column(("sensitivities.csv",), "value", "*", "d(output)/d(parameter) at the run's equilibrium or periodic "
                                                 "state (unit in the unit column; per degree for angle keys)"),
    Column(("sensitivities.csv",), "unit", "-", "the unit of value: the output's unit over the parameter's"),
    Column(("sensitivities_refined.csv",), "output", "-", "as in sensitivities.csv, joints numbered as at the "
                                                          "deck's own n (refined runs with &design)"),
    Column(("sensitivities_refined.csv",), "parameter", "-", "the &design parameter"),
    Column(("sensitivities_refined.csv",), "unit", "-", "the unit of the values: the output's over the parameter's"),
    Column(("sensitivities_refined.csv",), "n{n}", "*", "d(output)/d(parameter) at n bodies"),
    Column(("sensitivities_refined.csv",), "extrapolated", "*", "its Richardson extrapolation: the converged "
                                                                "sensitivity"),
    Column(("sensitivities_refined.csv",), "error_estimate", "*", "its error estimate"),
    Column(("sensitivities_refined.csv",), "observed_order", "-", "observed order of convergence of the "
                                                                  "sensitivity (assumed: 2 levels)"),
    Column(("sensitivities_refined.csv",), "order_observed", "-", "1: observed over 3 levels and used, 0: the "
                                                                  "expected order used"),
    # -- design optimisation (analysis = 'design') ---------------------------------------------------------
    Column(("design_history.csv",), "start", "-", "the optimiser's start (&design starts): 'deck' (the deck's "
                                                   "values), 'all lower', 'all upper' (the box's corners)"),
    Column(("design_history.csv",), "pass", "-", "1; 2: the pass from the first pass's optimum with the "
                                                 "discretisation shift taken there (&design frequency_levels > 1)"),
    Column(("design_history.csv",), "iteration", "-", "per start, 0: its start design; then one row per optimiser "
                                                      "iteration"),
    Column(("design_history.csv",), "{group}.{key}", "*", "a &design parameter's value (its unit from "
                                                         "docs/deck_reference.md)"),
    Column(("design_history.csv",), "objective", "*", "the &design objective (N or Nm or Hz or 1/h, by the "
                                                      "objective)"),
    Column(("design_history.csv",), "f1_hz", "Hz", "first UNDAMPED frequency (with frequency_margin_percent; not "
                                                   "what the margin judges)"),
    Column(("design_history.csv",), "fd{k}_hz", "Hz", "DAMPED frequency of mode k, each mode the margin constrains "
                                                      "(shifted to the converged cable with &design frequency_levels > "
                                                      "1; blank in the rows of a start that does not constrain it)"),
    Column(("design_history.csv",), "frequency_margin_percent", "%",
           "the least margin of the constrained modes' damped frequencies from the excited k/rev (&resonance "
           "harmonics, excitation) at the operating speed(s), as resonance.csv's margin_percent"),
    Column(("design_history.csv",), "margin_mode", "-", "the mode of that least margin"),
    # -- refinement ----------------------------------------------------------------------------------------
    Column(("refinement.csv",), "quantity", "-", "what is extrapolated (its unit in the column unit)"),
    Column(("refinement.csv",), "unit", "-", "the quantity's unit"),
    Column(("refinement.csv",), "n{n}", "*", "the quantity at n bodies"),
    Column(("refinement.csv",), "extrapolated", "*", "Richardson extrapolation"),
    Column(("refinement.csv",), "error_estimate", "*", "its error estimate"),
    Column(("refinement.csv",), "observed_order", "-", "observed order of convergence (assumed: 2 levels)"),
    Column(("refinement.csv",), "order_observed", "-", "1: observed over 3 levels, 0: assumed"),
    Column(("refinement.csv",), "asymptotic", "-",
           "1: the values are in the asymptotic range (observed order near the expected one); 0: not yet, the "
           "error estimate then covers the extrapolations with both orders"),
    # -- sweep -----------------------------------------------------------------------------------------------
    Column(SWEEP, "id", "-", "grid point"),
    Column(SWEEP, "{group}.{key}", "*", "a swept deck key (its unit from docs/deck_reference.md)"),
    Column(SWEEP, "analysis", "-", "analysis of the run"),
    Column(SWEEP, "wall_time_s", "s", "computing time of the run"),
    Column(SWEEP, "max_constraint_violation_m", "m", "largest constraint violation"),
    Column(SWEEP, "f{k}_hz", "Hz", "undamped frequency of mode k"),
    Column(SWEEP, "f1_damped_hz", "Hz", "first damped frequency"),
    Column(SWEEP, "zeta1", "-", "first damping ratio"),
    Column(SWEEP, "energy_drift_rel", "-", "relative energy drift of a dynamic run"),
    Column(SWEEP, "solver_{counter}", "-", "solver statistics (steps, residuals, ...)"),
    Column(SWEEP, "error", "-", "the error of a failed run"),
    # -- studies (rotorcable study NAME; pydriver/study.py, pydriver/design_study.py) -------------------
    # The column's name is kept from before the units (an output column is never renamed).
    Column(("frequency_vs_cy.csv",), "c_y_Nm_per_rad", "Nm/rad",
           "the bending spring of every joint, &springs c_beta (the thesis's c_y), of uh60_part2_modal.nml"),
    Column(("frequency_vs_cy.csv",), "f_undamped_hz", "Hz", "first undamped natural frequency"),
    Column(("frequency_vs_cy.csv",), "f_damped_hz", "Hz", "first damped frequency"),
    Column(("frequency_vs_cy.csv",), "zeta", "-", "damping ratio of the first mode"),
    Column(("flap_crossing.json",), "f_flap_hz", "Hz", "the blade's flap frequency the first frequency is compared with"),
    Column(("flap_crossing.json",), "c_y_Nm_per_rad", "Nm/rad",
           "&springs c_beta (the thesis's c_y) at which the first damped frequency equals f_flap_hz (bisection)"),
    Column(("flap_crossing.json",), "thesis_reading_Nm_per_rad", "Nm/rad", "the value the thesis reads off its "
                                                                           "Figure 5.9 (docs/model.md)"),
    Column(("refinement.json",), "n_bodies", "-", "the numbers of bodies the part 2 cable is cut into (n = 11, 22, 44, "
                                                  "88)"),
    Column(("refinement.json",), "f_undamped_hz", "Hz", "first undamped natural frequency at each n"),
    Column(("refinement.json",), "f_damped_hz", "Hz", "first damped frequency at each n"),
    Column(("refinement.json",), "observed_order_undamped", "-",
           "observed order of convergence of the undamped frequency over the three finest runs"),
    Column(("design_study.json",), "deck", "-", "the design deck the study ran"),
    Column(("design_study.json",), "objective", "-", "the &design objective minimised"),
    Column(("design_study.json",), "starts.{start}", "-",
           "the optimisation from one start ('deck': the deck's values; 'all lower', 'all upper': every "
           "parameter at its bound), as summary.json's design block: objective (start, optimum), parameters, "
           "iterations, runs, converged, message, frequency_margin"),
    Column(("design_study.json",), "starts.{start}.life_hours", "h", "the shortest fatigue life of that optimum at "
                                                                    "the deck's n"),
    Column(("design_study.json",), "starts.{start}.frequency_shifts_hz", "Hz",
           "f1(converged) - f1(n) of the hover state the frequency margin was judged with (one per pass)"),
    Column(("design_study.json",), "starts.{start}.optimum_changes", "*",
           "the optimum as deck changes, {\"group.key\": value} (units of the deck reference)"),
    Column(("design_study.json",), "best", "-", "the start whose converged optimum holds the margin with the "
                                                "least objective"),
    Column(("design_study.json",), "{state}.n", "-", "the numbers of bodies of the refined runs of the deck's design "
                                                     "(before) and of the best optimum (after)"),
    Column(("design_study.json",), "{state}.values_h", "h", "the shortest fatigue life at each n"),
    Column(("design_study.json",), "{state}.extrapolated_h", "h", "its Richardson extrapolation: the converged life"),
    Column(("design_study.json",), "{state}.error_estimate_h", "h", "its error estimate"),
    Column(("design_study.json",), "{state}.observed_order", "-", "the life's observed order of convergence"),
    Column(("design_study.json",), "{state}.warning", "-", "the refinement's warning about the life (empty: none)"),
    Column(("design_study.json",), "{state}.fd1_hz", "Hz",
           "the converged first damped frequency of the hover state (the one a resonance margin judges)"),
    Column(("design_study.json",), "{state}.fd1_error_hz", "Hz", "its error estimate"),
    Column(("design_study.json",), "{state}.fd1_values_hz", "Hz", "the first damped frequency at each n"),
    Column(("design_study.json",), "{state}.margin_mode", "-", "the mode closest to an excited harmonic"),
    Column(("design_study.json",), "{state}.nearest_harmonic", "-", "the rotor harmonic k nearest to it (k/rev)"),
    Column(("design_study.json",), "{state}.margin_percent", "%", "its distance from k/rev, in percent of k/rev"),
    Column(("design_study.json",), "{state}.worst_margin_percent", "%", "the margin narrowed by the error bar"),
    Column(("design_study.json",), "{state}.resonance", "-",
           "the refined run's resonance table (summary.json's resonance block: every mode's margin)"),
    Column(("design_study.json",), "required_margin_percent", "%", "&design frequency_margin_percent (null: none)"),
    Column(("design_study.json",), "life_gain", "-", "converged life after / converged life before"),
    Column(("design_study.json",), "warning", "-", "present when the optimum's converged first frequency is closer "
                                                   "to a harmonic than the required margin"),
]

_PLACEHOLDER = {"{coord}": "(?:gamma|beta|cardan_x|cardan_y|twist)", "{j}": r"\d+", "{k}": r"\d+",
                "{n}": r"\d+", "{c}": "[xyz]", "{a}": "[xy]", "{s}": "[AB]",
                "{q}": "(?:axial_N|shear_N|bending_Nm|torsion_Nm|strain)",
                "{group}": r"[a-z_]+", "{key}": r"[a-z_0-9]+(?:\(\d+\))?", "{counter}": r"[a-z_]+",
                "{state}": "(?:before|after)", "{start}": r"[^.]+"}
_FAT_STAT = re.compile(r"^(axial_N|shear_N|bending_Nm|torsion_Nm|strain)_(min|max|mean|amplitude)$")


def _regex(pattern: str) -> re.Pattern:
    out = re.escape(pattern)
    for ph, rx in _PLACEHOLDER.items():           # a named group each: column_meaning fills it in
        out = out.replace(re.escape(ph), f"(?P<{ph[1:-1]}>{rx})")
    if pattern == "{q}_{s}":
        return _FAT_STAT
    return re.compile(f"^{out}$")


_COMPILED = [(c, _regex(c.pattern)) for c in COLUMNS]
_UNIT = re.compile(r"^(.*?) \[([^\]]*)\]$")


def column_of(file: str, name: str) -> Column | None:
    """The table row of column ``name`` of ``file`` (None if it has none)."""
    for col, rx in _COMPILED:
        if file in col.files and rx.match(name):
            return col
    return None


def column_meaning(file: str, name: str, over: tuple = ()) -> str:
    """The meaning of column ``name`` of ``file`` with its placeholders filled in from the name
    (``FA_x``: "force support A exerts on the chain, x component"); the name itself if the
    table has no row for it.

    ``over`` names the placeholders a variable runs along instead (the netCDF variables of
    :mod:`pydriver.netcdf_layout`: ``j`` for the body or joint dimension, ``c`` for component,
    ``a`` for bending_axis): "joint {j}" becomes "each joint", and the component is left to its
    dimension.
    """
    for col, rx in _COMPILED:
        m = rx.match(name) if file in col.files else None
        if m is not None:
            break
    else:
        return name
    text = col.meaning
    if "j" in over:
        text = re.sub(r"\b(body|joint) \{j\}", r"each \1", text)
    if "c" in over:
        text = re.sub(r", \{c\} (?:component|coordinate)", "", text)
    if "a" in over:
        text = text.replace("local {a} axis", "local x and y axes")
    values = m.groupdict() if rx is not _FAT_STAT else {}
    return re.sub(r"\{(\w+)\}", lambda ph: values.get(ph.group(1)) or ph.group(0), text)


def unit_of(file: str, name: str, units: dict | None = None) -> str:
    """The unit of a column: ``units[name]`` if the writer knows it (a deck-dependent unit),
    else the table's, else the unit suffix of the name (``_N``, ``_deg`` ...), else '-'."""
    if units and name in units:
        return units[name]
    col = column_of(file, name)
    if col is not None and col.unit != "*":
        return col.unit
    if col is not None and column_of(file, "unit") is not None:
        return "*"                          # the row's own unit, in its `unit` cell (issue 36)
    m = _FAT_STAT.match(name)
    if m:
        return {"axial_N": "N", "shear_N": "N", "bending_Nm": "Nm", "torsion_Nm": "Nm", "strain": "-"}[m.group(1)]
    return "-"


def header(file: str, names: list[str], units: dict | None = None) -> list[str]:
    """The CSV header cells: every name with its unit in brackets."""
    return [f"{n} [{unit_of(file, n, units)}]" for n in names]


def bare_name(cell: str) -> str:
    """A header cell without its unit: ``'FA_x [N]'`` -> ``'FA_x'`` (old headers unchanged)."""
    m = _UNIT.match(cell.strip())
    return m.group(1) if m else cell.strip()


#: Keys of summary.json described here (the rest are named by their unit suffix and are described in
#: README.md): (key, unit, meaning).  A dotted key is one inside a group.
SUMMARY_KEYS: tuple[tuple[str, str, str], ...] = (
    ("equilibrium_stability.verdict", "-",
     "static and modal runs: 'stable', 'neutral' (a mode without stiffness: the equilibrium is not unique along "
     "it) or, refused as an error, 'unstable'; every analysis that starts from an equilibrium (design, dynamic "
     "from rest, flight) refuses an unstable one too (docs/model.md, \"Which equilibrium\")"),
    ("equilibrium_stability.smallest_stiffness_eigenvalue_Nm_per_rad", "Nm/rad",
     "smallest eigenvalue of the constrained tangent stiffness sym(N^T K N), N an orthonormal basis of the "
     "constraints' null space"),
    ("equilibrium_stability.lowest_omega_squared_per_s2", "1/s^2",
     "smallest w^2 of sym(K_r) phi = w^2 M_r phi (0 within its round-off floor; negative: unstable)"),
    ("equilibrium_stability.zero_stiffness_modes", "-", "how many modes have no stiffness"),
    ("equilibrium_stability.largest_growth_rate_per_s", "1/s",
     "largest real part of the damped linear system's eigenvalues (positive beyond round-off: divergence or "
     "flutter of the equilibrium)"),
    ("equilibrium_stability.distance_from_start.largest_point_displacement_m", "m",
     "largest distance a joint point moved from the start shape closed onto the supports (also as a share of "
     "the cable's length; above 0.25 a warning)"),
    ("equilibrium_stability.distance_from_start.largest_angle_change_deg", "deg",
     "largest change of a joint coordinate from that start"),
    ("zero_stiffness_modes", "-", "modal runs: the modes set to 0 Hz (numbers, from 1)"),
    ("integration_error.method", "-",
     "dynamic and flight runs: how the run estimated its own integration error (the whole run, or a flight's "
     "last revolution, again at rtol/100), or 'not estimated' with the reason in `why`"),
    ("integration_error.relative_change.{family}", "-",
     "per family (support reactions, joint loads, jacket strain): the largest change of a sampled value in the "
     "check pass over the family's largest value; the run's error to ~1 %; above 1e-3 a warning"),
    ("integration_error.shortest_life_relative_change", "-",
     "flight runs with &fatigue: relative change of the shortest fatigue life in the check pass (above 1e-2 a "
     "warning)"),
    ("integration_error.check_rtol", "-", "the check pass's rtol (its atol in check_atol)"),
)


def outputs_document(file: str = ""):
    """The output reference as a :class:`pydriver.document.Document`: every output file and its
    columns (``docs/outputs.md``, ``rotorcable outputs``); ``file`` narrows it to one file
    (``fatigue.csv``, or ``fatigue``).

    Raises
    ------
    ValueError
        ``file`` is no output file; the message lists them.
    """
    from pydriver.document import Document, Section, Table

    doc = Document("Output files", source_note=(
        "Generated from `pydriver/output_columns.py` by `python -m pydriver.output_columns`; do not edit by "
        "hand (CI checks that this file is current).  The installed program prints the same reference: "
        "`rotorcable outputs [FILE]`."))
    doc.paragraphs += [
        "Every CSV header carries its column's unit in brackets, e.g. `FA_x [N]` (`[-]`: dimensionless). "
        "`pydriver.load_results` and `pydriver.output.read_csv` give the columns by their bare names "
        "(`FA_x`), as before units were added.  `{j}` is a joint or body number (from clamp A), `{k}` a "
        "mode, `{n}` a number of bodies, `{c}` one of x, y, z, `{a}` one of x, y, `{s}` a support, A or B. "
        "A unit `*` depends on the deck (the S-N curve's quantity) or on the row (refinement.csv's and "
        "sensitivities.csv's `unit`; their headers say `[*]` there). "
        "`timeseries.h5` (large runs, or `&solver output_format = 'hdf5'`) is netCDF4: "
        "`xarray.open_dataset(path, engine='h5netcdf')` opens it with dimensions time, body, joint, "
        "component and bending_axis; the columns below are grouped into variables `cm`, `F_A`, `M_A`, `F_B`, "
        "`M_B` (and the loads on the supports `F_A_on_support` ... `M_B_on_support`), `tip`, `gamma`, `beta`, "
        "`axial`, `shear`, `bending`, `torsion`, `curvature`, `strain`, "
        "`moment`, `kappa` (the rest keep their names), each with `units` and `long_name` attributes "
        "(`pydriver/netcdf_layout.py`).  "
        "A blank cell is a value that does not exist (a life without damage, a crossing missing at one "
        "refinement level); no file holds NaN or Inf.",
        "Besides the tables: `summary.json` (every scalar result, warnings, solver statistics), "
        "`table.txt` (the equilibrium in the layout of the thesis's appendix; English, or German with "
        "`&output table_language = 'de'`), `report.html` (with the cable's animation for flight and dynamic "
        "runs), the PNG plots, `checkpoint.npz` (dynamic runs: the end state for `run --restart`), `cable.pvd` "
        "and `cable_NNNN.vtu` (`--vtk`: a ParaView time series of the "
        "cable, point data strain, bending moment, damage and the jacket radius `radius_m`, cell data each "
        "body's `axis` and `normal` (its twist); a static run's equilibrium, one frame), "
        "`mode<k>.pvd` and `mode<k>_NN.vtu` (`--vtk`, modal and Campbell runs: mode k over one period in 24 "
        "frames, point data `displacement_m` [m]), and `.rotorcable-run.json` (the marker: "
        "program, kind of output (`run`, `study <name>`, `sweep`, `sweep error`), deck, the directory it "
        "was written to and the files it wrote; a later output replaces only an earlier one of the "
        "same kind, and deletes only the files listed there, `pydriver/ownership.py`).  A sweep "
        "directory has one too, listing the files the sweep wrote itself (`sweep.json`, `decks/`, "
        "`sweep.csv`, `plots/`, `report.html`, `sweep.slurm`); each record in `runs/<id>/` has its own.  "
        "The studies (`rotorcable study NAME`) write `frequency_vs_cy.csv` and `flap_crossing.json` "
        "(cy-sweep), `refinement.json` (refine) and `design_study.json` (design), each with its plots; a "
        "dotted key of a JSON file is a key inside a group."]
    files = sorted({f for c in COLUMNS for f in c.files})
    wanted = file.strip()
    if wanted:
        chosen = [f for f in files if wanted in (f, f.rsplit(".", 1)[0])]
        if wanted in ("summary", "summary.json"):
            chosen = ["summary.json"]
        if not chosen:
            close = difflib.get_close_matches(wanted, files + ["summary.json"], n=3, cutoff=0.5)
            raise ValueError(f"'{file}' is no output file" + (f"; did you mean {' or '.join(close)}?" if close else "")
                             + " The files: " + ", ".join(files + ["summary.json"]))
        files = [f for f in chosen if f != "summary.json"]
    for f in files:
        what = "key" if f.endswith(".json") else "column"
        table = Table((what, "unit", "meaning"),
                      [(f"`{c.pattern}`", c.unit, c.meaning) for c in COLUMNS if f in c.files])
        doc.sections.append(Section(f"`{f}`", table=table))
    if not wanted or wanted in ("summary", "summary.json"):
        doc.sections.append(Section("`summary.json` (selected keys)", table=Table(
            ("key", "unit", "meaning"), [(f"`{key}`", unit, meaning) for key, unit, meaning in SUMMARY_KEYS])))
    return doc


def outputs_markdown() -> str:
    """``docs/outputs.md``: every output file and its columns (generated)."""
    from pydriver.document import markdown
    return markdown(outputs_document())


def main(argv=None) -> int:
    """Write ``docs/outputs.md`` (or PATH; installed: print it, see
    pydriver.reference_output.write_generated)."""
    argv = sys.argv[1:] if argv is None else argv
    return write_generated(argv, "outputs.md", outputs_markdown(), "# Output files")


if __name__ == "__main__":
    sys.exit(main())
