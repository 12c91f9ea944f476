"""Converged design sensitivities: the sensitivities of a refined run (``&refinement levels > 1``
with ``&design parameters``) extrapolated over n, 2n, 4n bodies (issue 24).

Each level computes its own sensitivities (:func:`pydriver.analyses.sensitivities.attach_sensitivities`,
the parameters' models rebuilt at that n).  The chain is a discretisation of order q of the
cable: an output converges as y(n; p) = y0(p) + C(p) n^-q.  Differentiating in p, the
sensitivity converges the same way with the same formal order q,

    dy/dp (n; p) = dy0/dp + (dC/dp) n^-q,

so the converged sensitivity dy0/dp is the Richardson extrapolation of the sensitivities
themselves (:func:`pydriver.richardson.richardson` on three levels, with their observed order
where it agrees with the expected one; :func:`pydriver.richardson.richardson_two` on two), with
the same error estimate as any refined number.  This is the derivative of the converged value,
not the derivative of the extrapolation formula (which would add the derivative of an observed
order that the asymptotics say is constant); the two agree in the asymptotic range.

Outputs are matched across levels by what they measure, not by index: joint j of the deck's
n is the same material point as joint (j - 1) k + 1 at k n bodies (every body splits into k equal
parts, :func:`pydriver.analyses.refinement.refined_deck`).  Reactions, frequencies and the
clamps' damage-equivalent loads keep their names.  Refined sensitivities are named as the deck's
own n names them.
"""

from __future__ import annotations

import re

from pydriver.richardson import richardson, richardson_two

#: Outputs at a joint: ``<stem><j><tail>`` (static joint loads ``bending3_Nm``, flight and dynamic
#: ``bending3_peak``, ``strain3_amplitude``, ``damage_per_hour3``, ``del_amplitude3``).  Mode
#: numbers (``f1_hz``) are not joints.
_AT_JOINT = re.compile(r"^(axial|shear|bending|torsion|curvature|strain|bend_angle|damage_per_hour|del_amplitude)"
                       r"(\d+)(_[A-Za-z_]+)?$")


def name_at_level(name: str, factor: int) -> str:
    """The name of the deck's output ``name`` in a run with every body split into ``factor``."""
    m = _AT_JOINT.match(name)
    if not m:
        return name
    stem, j, tail = m.group(1), int(m.group(2)), m.group(3) or ""
    return f"{stem}{(j - 1) * factor + 1}{tail}"


def refine_sensitivities(level_sensitivities: list[dict], ns: list[int],
                         expected_order: float) -> tuple[dict, dict, list[str]]:
    """summary['sensitivities']['refined'], the rows of sensitivities_refined.csv and the warnings,
    from each level's summary['sensitivities'] (coarse to fine) at ns = (n, 2n, 4n ...)."""
    coarse = level_sensitivities[0]
    factors = [n // ns[0] for n in ns]
    table, errors, units = {}, {}, {}
    rows = {"output": [], "parameter": [], "unit": [], **{f"n{n}": [] for n in ns},
            "extrapolated": [], "error_estimate": [], "observed_order": [], "order_observed": []}
    warned = []
    for output, by_parameter in coarse["d_output_d_parameter"].items():
        names = [name_at_level(output, f) for f in factors]
        for parameter in by_parameter:
            try:
                values = [float(s["d_output_d_parameter"][n][parameter]) for s, n in zip(level_sensitivities, names)]
            except KeyError:
                continue                       # not an output at every level (e.g. a mode lost)
            if len(values) == 2:
                e = richardson_two(*values, expected_order=expected_order)
                observed = False
            else:
                e = richardson(*values[-3:], expected_order=expected_order)
                observed = e.warning is None
                if e.warning:
                    warned.append(f"{output}/{parameter}")
            unit = coarse["units"][output][parameter]
            table.setdefault(output, {})[parameter] = e.extrapolated
            errors.setdefault(output, {})[parameter] = e.error_estimate
            units.setdefault(output, {})[parameter] = unit
            rows["output"].append(output)
            rows["parameter"].append(parameter)
            rows["unit"].append(unit)
            for n, v in zip(ns, values):
                rows[f"n{n}"].append(v)
            rows["extrapolated"].append(e.extrapolated)
            rows["error_estimate"].append(e.error_estimate)
            rows["observed_order"].append(e.observed_order)
            rows["order_observed"].append(observed)
    summary = {"n": list(ns), "expected_order": expected_order,
               "method": "Richardson extrapolation of each level's sensitivities (docs/model.md, \"Converged "
                         "design sensitivities\"); outputs at joints named by the deck's own n",
               "d_output_d_parameter": table, "error_estimate": errors, "units": units}
    warnings = []
    if warned:
        summary["not_in_asymptotic_range"] = warned
        warnings.append(f"refined sensitivities: {len(warned)} of {len(rows['output'])} are not in the asymptotic "
                        "range at these n (extrapolated with the expected order; order_observed = 0 in "
                        "sensitivities_refined.csv, error estimates widened as for refined values)")
    return summary, rows, warnings
