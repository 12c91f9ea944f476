"""Python face of the Fortran core: run a deck, raise its errors, return numpy results."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver import _rotorcable

_core = _rotorcable.rotorcable_api

ANALYSES = {1: "static", 2: "dynamic", 3: "modal"}
SOLVER_KEYS_DYNAMIC = ("steps", "residual_evals", "jacobian_evals", "error_test_failures",
                       "convergence_failures")
SOLVER_KEYS_STATIC = ("newton_iterations", "residual_evals", "jacobian_evals", "line_search_cuts")


class DeckError(ValueError):
    """A deck that cannot be run: names the deck, the namelist group, the key and the reason."""

    def __init__(self, deck: str, group: str, key: str, reason: str):
        self.deck, self.group, self.key, self.reason = deck, group, key, reason
        where = f"&{group}" if group else ""
        if key:
            where += f" key '{key}'"
        super().__init__(f"deck '{deck}': {where.strip() or 'file'}: {reason}")


class RunError(RuntimeError):
    """A valid deck whose run failed (solver did not converge, singular system, ...)."""


@dataclass
class Result:
    """Outcome of one deck run.

    Attributes
    ----------
    summary : dict
        The content of ``summary.json``.
    table : dict of numpy arrays or None
        Equilibrium table columns (``body, gamma_deg, beta_deg, x_m, y_m, z_m``).
    timeseries : dict of numpy arrays or None
        Time-series columns (``t``, ``x1`` ..., ``gamma1_deg`` ..., reactions).
    extra : dict
        Arrays not written to the CSV files (coordinates, energy, constraint violation).
    """

    summary: dict
    table: dict | None = None
    timeseries: dict | None = None
    extra: dict = field(default_factory=dict)


def _text(x) -> str:
    if isinstance(x, np.ndarray):
        x = x.tobytes()
    if isinstance(x, bytes):
        x = x.decode(errors="replace")
    return str(x).strip()


def _check(path: str, stat: int, group="", key="", msg=""):
    if stat != 0:
        if stat == 1:
            raise DeckError(os.path.basename(path), _text(group), _text(key), _text(msg))
        raise RunError(f"deck '{os.path.basename(path)}': {_text(msg)}")


def deck_info(path) -> dict:
    """Read and validate a deck; return its sizes, analysis type and case name.

    Raises
    ------
    DeckError
        If the deck is missing, malformed or physically inconsistent.
    """
    path = str(path)
    if not os.path.isfile(path):
        raise DeckError(os.path.basename(path), "", "", "deck file not found")
    (nb, nq, nc, nt, analysis, c_beta, name, pulse_body, pulse_end, stat, group, key,
     msg) = _core.rc_deck_info(path)
    _check(path, stat, group, key, msg)
    return {"n_bodies": int(nb), "n_coords": int(nq), "n_constraints": int(nc), "n_out": int(nt),
            "analysis": ANALYSES[int(analysis)], "c_beta": float(c_beta),
            "case": _text(name) or Path(path).stem, "pulse_body": int(pulse_body),
            "pulse_end": float(pulse_end)}


def shape(path, q) -> dict:
    """Joint angles [deg], centres of mass and joint points [m] of the deck's chain at ``q``."""
    info = deck_info(path)
    ang, cm, joints, stat, msg = _core.rc_shape(str(path), info["n_bodies"], np.asarray(q, float))
    _check(str(path), stat, msg=msg)
    return {"angles_deg": ang, "cm": cm, "joints": joints}


def evaluate_model(path, q, v=None, vdot=None, lam=None, t=0.0) -> dict:
    """Every model quantity of the deck's chain at one state (for tests and analysis).

    Returns a dict with ``M`` (composite-rigid-body), ``M_jourdain`` (thesis eq. 4.87),
    ``k``, ``residual`` (M vdot - k - G^T lambda by inverse dynamics), ``g``, ``G``,
    ``Gdot_v``, ``G_v``, ``vdot``/``lambda`` of eq. 3.55, ``wrenches`` (F_A, M_A, F_B, M_B)
    and ``energy``.
    """
    info = deck_info(path)
    nq, nc = info["n_coords"], info["n_constraints"]
    q = np.asarray(q, float)
    v = np.zeros(nq) if v is None else np.asarray(v, float)
    vdot = np.zeros(nq) if vdot is None else np.asarray(vdot, float)
    lam_in = np.zeros(max(nc, 1))
    if lam is not None and nc:
        lam_in[:nc] = lam
    out = _core.rc_evaluate(str(path), float(t), q, v, vdot, lam_in)
    (m, mj, k, res, g, gj, gb, gv, vd, la, wr, en, stat, msg) = out
    _check(str(path), stat, msg=msg)
    return {"M": m, "M_jourdain": mj, "k": k, "residual": res, "g": g[:nc], "G": gj[:nc],
            "Gdot_v": gb[:nc], "G_v": gv[:nc], "vdot": vd, "lambda": la[:nc], "wrenches": wr,
            "energy": float(en)}


def _reactions(w, has_b: bool) -> dict:
    out = {"A": {"F": [float(x) for x in w[0:3]], "M": [float(x) for x in w[3:6]]}}
    if has_b:
        out["B"] = {"F": [float(x) for x in w[6:9]], "M": [float(x) for x in w[9:12]]}
    return out


def _equilibrium_summary(path, info, kind, wall, st, gmax, wr) -> dict:
    nc = info["n_constraints"]
    return {"case": info["case"], "deck": os.path.basename(path), "analysis": kind,
            "wall_time_s": wall,
            "solver": dict(zip(SOLVER_KEYS_STATIC, (int(x) for x in st[:4]))),
            "max_constraint_violation_m": float(gmax),
            "reactions": _reactions(wr, nc > 0),
            "n_bodies": info["n_bodies"], "n_coords": info["n_coords"], "n_constraints": nc,
            "c_beta_Nm_per_rad": info["c_beta"]}


def _table(nb, ang, cm) -> dict:
    return {"body": np.arange(1, nb + 1), "gamma_deg": ang[:, 0], "beta_deg": ang[:, 1],
            "x_m": cm[:, 0], "y_m": cm[:, 1], "z_m": cm[:, 2]}


def _run_modal(path, info, t0) -> Result:
    nb, nq, nc = info["n_bodies"], info["n_coords"], info["n_constraints"]
    nf = nq - nc
    (q, lam, ang, cm, wr, fu, fd, zeta, shapes, cm_shapes, st, gmax, stat, group, key, msg) = \
        _core.rc_run_modal(path, nb, nq, max(nc, 1), nf)
    _check(path, stat, group, key, msg)
    summary = _equilibrium_summary(path, info, "modal", time.perf_counter() - t0, st, gmax, wr)
    summary["frequencies_hz"] = [float(x) for x in fu]
    summary["damped_frequencies_hz"] = [float(x) for x in fd]
    summary["damping_ratios"] = [float(x) for x in zeta]
    # Mode shapes as CM displacements, each scaled to a largest component of 1.
    scale = np.max(np.abs(cm_shapes), axis=0)
    scale[scale == 0] = 1.0
    modes = {"mode": np.arange(1, nf + 1), "f_undamped_hz": fu, "f_damped_hz": fd, "zeta": zeta}
    for j in range(nb):
        for c, name in enumerate("xyz"):
            modes[f"d{name}{j + 1}"] = cm_shapes[3 * j + c] / scale
    return Result(summary=summary, table=_table(nb, ang, cm),
                  extra={"q": q, "lambda": lam[:nc], "modes": modes, "mode_shapes_q": shapes})


def _straight_zy_warnings(path, info, result) -> list:
    """Warn where the thesis's zy joint sits at beta = 0 in a result.

    There gamma is a twist, so the joint has lost one bending direction: a load across it
    does no work on any coordinate at first order and is silently carried as if the cable
    were rigid sideways (docs/model.md, tests/test_hard_cases.py).  ``&chain joint = 'xy'``
    has no such point.
    """
    kinds, free, stat, msg = _core.rc_joint_kinds(path, info["n_bodies"])
    _check(path, stat, msg=msg)
    if result.table is not None:
        beta = np.asarray(result.table["beta_deg"], float)
    else:
        beta = np.array([np.min(np.abs(np.sin(np.radians(result.timeseries[f"beta{j + 1}_deg"]))))
                         for j in range(info["n_bodies"])])
        beta = np.degrees(np.arcsin(beta))
    straight = [j + 1 for j in range(info["n_bodies"])
                if kinds[j] == 1 and free[j] and abs(np.sin(np.radians(beta[j]))) < 1e-6]
    if not straight:
        return []
    return [f"joints {straight} of the thesis's zy parametrisation are straight (beta = 0), where "
            "gamma is a twist and the joint cannot bend sideways: loads across those joints are "
            "carried as if the cable were rigid there; use &chain joint = 'xy' (Cardan bending)"]


def run_deck(path, out=None, plots: bool = False) -> Result:
    """Run a deck and return its results; write files only when ``out`` is given.

    Parameters
    ----------
    path : str or Path
        Fortran namelist deck (see ``inputs/``).
    out : str or Path, optional
        Output directory; ``summary.json`` and the tables/time series are written there
        atomically (a failed run leaves nothing behind).
    plots : bool
        Also write PNG plots (needs matplotlib).

    Returns
    -------
    Result

    Raises
    ------
    DeckError
        Bad input, naming the deck, group, key and reason.
    RunError
        The solver failed on a valid deck.
    """
    path = str(path)
    info = deck_info(path)
    nb, nq, nc = info["n_bodies"], info["n_coords"], info["n_constraints"]
    t0 = time.perf_counter()
    if info["analysis"] == "modal":
        result = _run_modal(path, info, t0)
    elif info["analysis"] == "static":
        (q, lam, ang, cm, wr, st, gmax, stat, group, key, msg) = _core.rc_run_static(
            path, nb, nq, max(nc, 1))
        _check(path, stat, group, key, msg)
        wall = time.perf_counter() - t0
        table = {"body": np.arange(1, nb + 1), "gamma_deg": ang[:, 0], "beta_deg": ang[:, 1],
                 "x_m": cm[:, 0], "y_m": cm[:, 1], "z_m": cm[:, 2]}
        summary = {"case": info["case"], "deck": os.path.basename(path), "analysis": "static",
                   "wall_time_s": wall,
                   "solver": dict(zip(SOLVER_KEYS_STATIC, (int(x) for x in st[:4]))),
                   "max_constraint_violation_m": float(gmax),
                   "reactions": _reactions(wr, nc > 0),
                   "n_bodies": nb, "n_coords": nq, "n_constraints": nc, "c_beta_Nm_per_rad": info["c_beta"]}
        result = Result(summary=summary, table=table,
                        extra={"q": q, "lambda": lam[:nc]})
    else:
        nt = info["n_out"]
        (t, q, ang, cm, wr, energy, gviol, st, stat, group, key, msg) = _core.rc_run_dynamic(
            path, nb, nq, nt)
        _check(path, stat, group, key, msg)
        wall = time.perf_counter() - t0
        ts = {"t": t}
        for j in range(nb):
            for c, name in enumerate("xyz"):
                ts[f"{name}{j + 1}"] = cm[:, 3 * j + c]
        for j in range(nb):
            ts[f"gamma{j + 1}_deg"] = ang[:, 2 * j]
            ts[f"beta{j + 1}_deg"] = ang[:, 2 * j + 1]
        names = ["FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z"]
        if nc > 0:
            names += ["FB_x", "FB_y", "FB_z", "MB_x", "MB_y", "MB_z"]
        for i, name in enumerate(names):
            ts[name] = wr[:, i]
        summary = {"case": info["case"], "deck": os.path.basename(path), "analysis": "dynamic",
                   "wall_time_s": wall,
                   "solver": dict(zip(SOLVER_KEYS_DYNAMIC, (int(x) for x in st))),
                   "max_constraint_violation_m": float(np.max(gviol)) if nc else 0.0,
                   "reactions": _reactions(wr[-1], nc > 0),
                   "t_end_s": float(t[-1]), "n_samples": int(nt),
                   "energy_drift_rel": float(np.max(np.abs(energy - energy[0]))
                                             / max(abs(energy[0]), 1e-300)),
                   "n_bodies": nb, "n_coords": nq, "n_constraints": nc}
        result = Result(summary=summary, timeseries=ts,
                        extra={"q": q, "energy": energy, "constraint_violation": gviol})
        if info["pulse_body"] > 0:
            from pydriver.signal import decay_analysis
            signal = f"z{info['pulse_body']}"
            result.summary["decay"] = decay_analysis(t, ts[signal], signal, info["pulse_end"])
    warnings = _straight_zy_warnings(path, info, result)
    if warnings:
        result.summary["warnings"] = warnings
    if out is not None:
        from pydriver.output import write_result
        write_result(result, Path(out), plots=plots)
    return result
