"""``run_deck``: read a deck once, build its model once, run its analysis, write its files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pydriver.analyses import run
from pydriver.model import Model
from pydriver.output import RunDirectory, write_files
from pydriver.progress import report as report_progress
from pydriver.errors import RunError
from pydriver.run_result import Result, require_finite


def run_deck(path, out=None, plots: bool = False, report: bool = False, vtk: bool = False,
             restart=None) -> Result:
    """Run a deck and return its results; write files only when ``out`` is given.

    Parameters
    ----------
    path : str or Path or Model
        Fortran namelist deck (see ``inputs/``), or a :class:`~pydriver.model.Model`.
    out : str or Path, optional
        Output directory.  It ends up holding exactly this run's files (``summary.json`` and
        the tables, time series, modes and plots of the analysis), all or none: a failed run
        leaves it as it was.
    plots : bool
        Also write PNG plots (needs matplotlib).
    report : bool
        Also write ``report.html``, one self-contained page with the inputs, results, plots and
        (flight and dynamic runs) an animation of the cable.
    vtk : bool
        Also write the cable for ParaView (:mod:`pydriver.paraview`): ``cable.pvd`` and
        ``cable_NNNN.vtu``, the time series of a flight or dynamic run or the equilibrium of a
        static one, and each mode of a modal or Campbell run as an animation, ``mode<k>.pvd``.
    restart : str or Path, optional
        A finished dynamic run's directory to continue from its end to this deck's ``t_end``
        (:mod:`pydriver.checkpoint`); the deck must describe the same model.  Its files are
        read, never written; the whole continued run goes to ``out``.

    Returns
    -------
    Result

    Raises
    ------
    DeckError
        Bad input, naming the deck, group, key and reason (a
        :class:`~pydriver.checkpoint.CheckpointError` for a ``restart`` directory whose files
        cannot be continued, naming the file).
    RunError
        The solver failed on a valid deck; or ``vtk`` on an analysis with no cable to draw (a
        usage spectrum), before anything runs.
    OutputError
        ``out`` is a directory holding files rotorcable did not write, a file, a link, the
        working directory or one of its parents (raised before the computation; nothing is
        touched).
    OSError
        The output directory cannot be written (raised before the computation).
    """
    model = path if isinstance(path, Model) else Model.from_deck(path)
    from pydriver.analyses.registry import analysis_of
    if vtk and not analysis_of(model).draws:
        raise RunError(f"deck '{model.name}': --vtk: a {model.analysis} run keeps no cable to draw (no time series, "
                       "equilibrium or modes); run one of its decks with --vtk")
    checkpoint = None
    if restart is not None:
        # Everything in the directory being continued is input: checked before anything is
        # computed or written, and never written to (the continuation writes to ``out``).
        from pydriver.checkpoint import continuation
        checkpoint = continuation(model, restart)
    if out is None:
        result = run(model, restart=checkpoint)
        require_finite(result, model.name)
        return result
    with RunDirectory(Path(out), deck=model.name) as run_dir:
        result = run(model, run_dir, restart=checkpoint)
        require_finite(result, model.name)
        report_progress("writing the files" + (" and plots" if plots else ""))
        write_files(result, run_dir, plots, table_language=model.deck["output.table_language"])
        # A time series kept on disk only (too large for memory) is read back at the frames.
        on_disk = None
        if result.timeseries is None:
            on_disk = next((p for p in map(run_dir.path, ("timeseries.h5", "timeseries.csv")) if p.exists()), None)
        if vtk:
            from pydriver.paraview import write_vtk
            report_progress("writing the ParaView series (--vtk)")
            write_vtk(result, run_dir, on_disk, model)
        if report:
            from pydriver.report_html import html_report
            report_progress("writing report.html")
            run_dir.path("report.html").write_text(html_report(result, model, on_disk), encoding="utf-8")
            result.files["report.html"] = run_dir.out / "report.html"
        run_dir.commit()
    return result


def deck_info(path) -> dict:
    """Read, validate and build a deck; return its sizes, analysis and case name."""
    m = Model.from_deck(path)
    return {"n_bodies": m.n_bodies, "n_coords": m.nq, "n_constraints": m.nc, "analysis": m.analysis,
            "case": m.case, "pulse_body": int(m.deck["loads.pulse_body"]),
            "pulse_end": float(m.deck["loads.pulse_end"])}


def _model(path_or_model) -> Model:
    return path_or_model if isinstance(path_or_model, Model) else Model.from_deck(path_or_model)


def shape(path, q, t: float = 0.0) -> dict:
    """Thesis angles [deg], centres of mass and joint points [m] of a deck's chain at ``q``."""
    m = _model(path)
    s = m.core.shape(np.asarray(q, float), t)
    return {"angles_deg": np.degrees(s["angles"]), "cm": s["cm"], "joints": s["joints"]}
