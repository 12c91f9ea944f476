"""PNG plots (matplotlib, Agg backend).

plot_result() draws what one run shows (shape, reactions, decay signal and spectrum, mode
frequencies) into a run's (temporary) directory and returns the file names.  The study
plots (rest vs hover shapes like thesis Figures 5.6/5.12, frequency against c_y like
Figure 5.9) are drawn by plot_shapes() and plot_frequency_vs_cy().
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from pydriver.analyses.registry import sections_of


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def legibility_problems(fig) -> list[str]:
    """What makes a figure hard to read: text that overlaps other text (labels, ticks, titles,
    legends, annotations; by more than 1 pixel) or another panel's frame, axes without a unit on
    an axis label, a legend over a line's data, labelled lines in one panel that look alike
    (colour within CIE76 delta E 12 and the same line style and marker), a 3-D panel not to
    scale, and an axis whose whole span is round-off (below 1e-9 of its values)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    from matplotlib.axis import Axis
    from matplotlib.text import Text
    # Tick labels only where the axis draws a tick (inside its view interval): matplotlib keeps
    # label artists of ticks beyond the limits, which are visible in name only.
    tick_labels, drawn = set(), []
    for axis in fig.findobj(match=Axis):
        for tick in axis.get_major_ticks() + axis.get_minor_ticks():
            tick_labels.update((id(tick.label1), id(tick.label2)))
        if axis.axes.get_visible():
            drawn += _drawn_tick_labels(axis)
    others = [t for t in fig.findobj(match=Text) if id(t) not in tick_labels]
    # Text artists only: a legend's TextArea wraps a Text that findobj also returns.
    texts = [t for t in others + drawn if t.get_visible() and t.get_text().strip() and t.figure is fig]
    boxes = [(t, t.get_window_extent(renderer).expanded(1.0, 1.0).padded(-1.0)) for t in texts]
    problems = []
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            if boxes[i][1].overlaps(boxes[j][1]):
                problems.append(f"'{boxes[i][0].get_text()}' overlaps '{boxes[j][0].get_text()}'")
    problems += _frame_problems(fig, boxes)
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        for axis in (ax.xaxis, ax.yaxis) + ((ax.zaxis,) if hasattr(ax, "zaxis") else ()):
            numbered = any(t.get_visible() and t.get_text() for t in axis.get_ticklabels())
            label = axis.get_label().get_text()
            # An axis that shows numbers needs a label with a unit; one sharing its neighbour's
            # numbers (sharex, tick labels hidden) needs none.
            if numbered and "[" not in label:
                problems.append(f"axis without a unit in its label: '{label}'")
    return problems + _legend_problems(fig, renderer) + _look_alike_problems(fig) + _scale_problems(fig)


def _is_3d(ax) -> bool:
    return hasattr(ax, "zaxis")


def _drawn_tick_labels(axis) -> list:
    """The tick labels an axis drew at the last draw (those inside its view interval).  A 3-D
    axis places its labels while drawing; asking it to update its ticks again would move them
    back to 2-D positions, so its labels are taken as the draw left them."""
    if not _is_3d(axis.axes):
        return [lab for tick in axis._update_ticks() for lab in (tick.label1, tick.label2)]
    lo, hi = sorted(axis.get_view_interval())
    eps = 1e-9 * max(abs(lo), abs(hi), hi - lo)
    return [tick.label1 for tick in axis.get_major_ticks() if lo - eps <= tick.get_loc() <= hi + eps]


def _frame_problems(fig, boxes) -> list[str]:
    """Text of one panel (or of the figure) that lies on another 2-D panel's frame or inside it
    (decay.png: the upper panel's "t [s]" on the lower panel's top edge)."""
    from matplotlib.text import Text
    owner = {}
    for ax in fig.axes:
        for t in ax.findobj(match=Text):
            owner[id(t)] = ax
    problems = []
    for t, box in boxes:
        o = owner.get(id(t))
        if o is not None and _is_3d(o) and t not in (o.xaxis.label, o.yaxis.label, o.zaxis.label):
            continue        # a 3-D panel places its tick labels while drawing; _declutter_3d sees them
        for ax in fig.axes:
            if ax is owner.get(id(t)) or _is_3d(ax) or not ax.get_visible() or not ax.axison:
                continue
            if box.overlaps(ax.bbox):
                problems.append(f"'{t.get_text()}' lies on the frame of another panel")
    return problems


def _legend_problems(fig, renderer) -> list[str]:
    """A legend whose box covers a drawn line (its points or the segments between them, in
    display coordinates, where they are inside their panel)."""
    from matplotlib.path import Path as MplPath
    from matplotlib.transforms import Bbox
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None] + list(fig.legends)
    problems = []
    for legend in legends:
        if not legend.get_visible():
            continue
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            if _is_3d(ax) or not ax.get_visible():
                continue
            inside = Bbox.intersection(box, ax.bbox)
            if inside is None or inside.width < 2 or inside.height < 2:
                continue
            inside = inside.padded(-1.0)
            for line in ax.get_lines():
                xy = np.asarray(line.get_xydata(), float)
                if not line.get_visible() or len(xy) == 0:
                    continue
                pts = line.get_transform().transform(xy)
                pts = pts[np.all(np.isfinite(pts), axis=1)]
                if len(pts) == 0:
                    continue
                hit = (inside.contains(*pts[0]) if len(pts) == 1
                       else MplPath(pts).intersects_bbox(inside, filled=False))
                if hit:
                    problems.append(f"legend ({', '.join(t.get_text() for t in legend.get_texts()[:3])} ...) "
                                    f"covers the line '{line.get_label()}'")
    return problems


def _lab(rgb) -> np.ndarray:
    """CIE L*a*b* (D65) of an sRGB colour, for telling colours apart as the eye does."""
    c = np.asarray(rgb[:3], float)
    c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]]) @ c
    xyz = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


#: CIE76 colour difference below which two lines look alike (about 2.3 is just noticeable; 12
#: keeps neighbouring lines of a legend apart at a glance).
LOOK_ALIKE_DELTA_E = 12.0


def _look_alike_problems(fig) -> list[str]:
    from matplotlib.colors import to_rgba
    problems = []
    for ax in fig.axes:
        lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_") and ln.get_visible()]
        for i, a in enumerate(lines):
            for b in lines[i + 1:]:
                if a.get_linestyle() != b.get_linestyle() or a.get_marker() != b.get_marker():
                    continue
                d = float(np.linalg.norm(_lab(to_rgba(a.get_color())) - _lab(to_rgba(b.get_color()))))
                if d < LOOK_ALIKE_DELTA_E:
                    problems.append(f"lines '{a.get_label()}' and '{b.get_label()}' look alike "
                                    f"(delta E {d:.1f}, same style)")
    return problems


def _scale_problems(fig) -> list[str]:
    problems = []
    for ax in fig.axes:
        if not ax.get_visible() or not (ax.axison or _is_3d(ax)):     # a 3-D panel draws its own axes
            continue
        lims = [ax.get_xlim(), ax.get_ylim()] + ([ax.get_zlim()] if _is_3d(ax) else [])
        # A 3-D panel's axes share one unit, so its largest span is a scale for every axis.
        panel = max(abs(hi - lo) for lo, hi in lims) if _is_3d(ax) else 0.0
        for name, (lo, hi) in zip("xyz", lims):
            if abs(hi - lo) < 1e-9 * max(abs(lo), abs(hi), panel):
                problems.append(f"{name} axis spans {abs(hi - lo):.1e} around {lo:.3g}: round-off drawn as data")
        if _is_3d(ax):
            spans = np.abs(np.diff(np.array(lims), axis=1)).ravel()
            per_unit = np.asarray(ax.get_box_aspect(), float) / spans
            if np.ptp(per_unit) > 0.02 * np.max(per_unit):
                problems.append("3-D panel not to scale: box aspect "
                                f"{np.round(ax.get_box_aspect(), 3).tolist()} against spans {spans.tolist()}")
    return problems


def _declutter_3d(fig, rounds: int = 6):
    """Resolve the collisions a 3-D view makes at drawing time (where its projection puts tick
    labels is known only then): a tick label meeting another tick label (at a corner, or on a
    short axis of a to-scale box) is hidden; an axis label meeting tick labels or another axis
    label moves out."""
    from mpl_toolkits.mplot3d import Axes3D
    for ax in [a for a in fig.axes if isinstance(a, Axes3D)]:
        axes = (ax.xaxis, ax.yaxis, ax.zaxis)
        for _ in range(rounds):
            fig.canvas.draw()
            r = fig.canvas.get_renderer()
            ticks = [(axis, lab, lab.get_window_extent(r)) for axis in axes for lab in _drawn_tick_labels(axis)
                     if lab.get_visible() and lab.get_text()]
            moved = False
            labels = []
            for axis in axes:
                box = axis.label.get_window_extent(r)
                if (any(b.overlaps(box) for _, _, b in ticks) or any(b.overlaps(box) for b in labels)) \
                        and axis.labelpad < 18:         # further out it leaves the panel
                    axis.labelpad += 4
                    moved = True
                labels.append(box)
            for i, (_, lab_i, b_i) in enumerate(ticks):
                for _, lab_j, b_j in ticks[i + 1:]:
                    # Also along one axis: a short axis of a to-scale box has little room.
                    if lab_i.get_visible() and b_i.overlaps(b_j):
                        lab_j.set_visible(False)
            if not moved:
                break


def _save(fig, out: Path, name: str) -> str:
    _declutter_3d(fig)
    return _write(fig, out, name)


def _write(fig, out: Path, name: str) -> str:
    plt = _plt()
    fig.savefig(Path(out) / name, dpi=110)
    plt.close(fig)
    return name


def _save_replace(fig, path: Path):
    """Save to a temporary name beside ``path`` and rename: a study plot is never half written."""
    plt = _plt()
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".png", dir=path.parent)
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def _polyline(t: dict):
    """The cable through its bodies' end points (joint points and the tip), or through the CMs
    for a table written before joint points were."""
    if "joint_x_m" in t:
        pts = np.column_stack([t["joint_x_m"], t["joint_y_m"], t["joint_z_m"]])
        if "tip_m" in t:
            pts = np.vstack([pts, t["tip_m"]])
        return pts
    return np.column_stack([t["x_m"], t["y_m"], t["z_m"]])


#: Values below this fraction of a panel's extent are round-off (1e-18 m on a 0.5 m cable) and
#: drawn as zero; a panel axis spans at least MIN_SPAN of the largest extent, so what is left of
#: round-off is never stretched into a zig-zag.
ROUND_OFF = 1e-12
MIN_SPAN = 0.1


def _snap(points: list[np.ndarray]) -> list[np.ndarray]:
    """The point sets with coordinates below ROUND_OFF of their common extent set to zero."""
    allp = np.vstack(points)
    scale = float(np.max(np.abs(allp))) if allp.size else 0.0
    return [np.where(np.abs(p) < ROUND_OFF * scale, 0.0, p) for p in points]


def _to_scale(ax, points: np.ndarray, margin: float = 0.05):
    """Limits and box of a 3-D panel such that one metre is as long on every axis (the spans
    are the data's, each at least MIN_SPAN of the largest, plus a margin)."""
    lo, hi = np.min(points, axis=0), np.max(points, axis=0)
    extent = float(np.max(hi - lo)) or float(np.max(np.abs(points))) or 1.0
    span = np.maximum(hi - lo, MIN_SPAN * extent) * (1.0 + 2.0 * margin)
    mid = 0.5 * (lo + hi)
    ax.set_xlim(mid[0] - span[0] / 2, mid[0] + span[0] / 2)
    ax.set_ylim(mid[1] - span[1] / 2, mid[1] + span[1] / 2)
    ax.set_zlim(mid[2] - span[2] / 2, mid[2] + span[2] / 2)
    ax.set_box_aspect(span / np.max(span), zoom=0.95)      # zoom: room for the axis labels


def _shape_axes(fig, tables: dict, clamped_b: bool = True):
    """3D view (to scale) and two side views (y-z, x-y) of the cable through its bodies' end
    points, one line per label; clamp A (square) and clamp B (triangle) marked; round-off
    drawn as zero."""
    # The 3-D view takes the left half over the figure's height (issue 37: one of three panels in a
    # row, it had been too small to read); the two side views are stacked on the right.
    grid = fig.add_gridspec(2, 2, width_ratios=[1.35, 1], wspace=0.3, hspace=0.35, left=0.02, right=0.84,
                            bottom=0.08, top=0.92)
    ax = fig.add_subplot(grid[:, 0], projection="3d")
    polylines = dict(zip(tables, _snap([_polyline(t) for t in tables.values()])))
    for label, p in polylines.items():
        line, = ax.plot(p[:, 0], p[:, 1], p[:, 2], "o-", ms=2.5, label=label)
        ax.plot(*p[0], "s", color=line.get_color(), ms=7)
        if clamped_b:
            ax.plot(*p[-1], "^", color=line.get_color(), ms=7)
    ax.set_xlabel("x [m]", labelpad=8); ax.set_ylabel("y [m]", labelpad=12); ax.set_zlabel("z [m]", labelpad=10)
    _to_scale(ax, np.vstack(list(polylines.values())))
    from matplotlib.ticker import MaxNLocator
    for axis, aspect in zip((ax.xaxis, ax.yaxis, ax.zaxis), ax.get_box_aspect() / np.max(ax.get_box_aspect())):
        # 3-D tick labels crowd otherwise (fewer on a short axis of a to-scale box); y's first
        # label sits in x's last one's corner.
        axis.set_major_locator(MaxNLocator(max(1, int(round(4 * aspect))),
                                           prune="lower" if axis is ax.yaxis else None))
    ax.tick_params(labelsize=7)
    for k, (a, b) in enumerate(((1, 2), (0, 1))):
        ax2 = fig.add_subplot(grid[k, 1])
        for label, p in polylines.items():
            line, = ax2.plot(p[:, a], p[:, b], "o-", ms=2.5, label=label)
            ax2.plot(p[0, a], p[0, b], "s", color=line.get_color(), ms=7)
            if clamped_b:
                ax2.plot(p[-1, a], p[-1, b], "^", color=line.get_color(), ms=7)
        ax2.set_xlabel("xyz"[a] + " [m]"); ax2.set_ylabel("xyz"[b] + " [m]")
        ax2.set_aspect("equal", adjustable="datalim"); ax2.grid(True)
    ax2.plot([], [], "ks", label="clamp A")
    if clamped_b:
        ax2.plot([], [], "k^", label="clamp B")
    ax2.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)


#: Colours that stay apart (matplotlib's tab10, Tableau's categorical palette) and the line
#: styles taken in turn once they run out.
DISTINCT_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink",
                   "tab:gray", "tab:olive", "tab:cyan")
LINE_STYLES = ("-", "--", ":", "-.")


def distinct_style(k: int) -> tuple[str, str]:
    """(colour, line style) of the k-th of many lines: no two of the first 40 alike."""
    return DISTINCT_COLORS[k % len(DISTINCT_COLORS)], LINE_STYLES[(k // len(DISTINCT_COLORS)) % len(LINE_STYLES)]


def _with_tip(result) -> dict:
    t = dict(result.table)
    if "tip_m" in result.summary:
        t["tip_m"] = np.asarray(result.summary["tip_m"])
    return t


def plot_flight(result, out: Path):
    """Forward flight: joint bending moments and clamp loads against the blade azimuth over the
    last revolution, and the cable at 8 azimuths."""
    plt = _plt()
    s, ts = result.summary, result.timeseries
    az = ts["azimuth_deg"]
    order = np.argsort(az)
    nb = s["n_bodies"]
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True, constrained_layout=True)
    # At most 8 joints, evenly along the cable (44 lines are a blur), the most loaded among them.
    shown = sorted(set(np.linspace(0, nb - 1, min(nb, 7)).round().astype(int))
                   | {int(np.argmax([np.max(ts[f"bending{j + 1}_Nm"]) for j in range(nb)]))})
    for k, j in enumerate(shown):
        # Distinct colours by rank, not a colormap by joint number: joints 30 and 31 were
        # neighbours on viridis and looked alike (issue 22).
        color, style = distinct_style(k)
        ax[0].plot(az[order], ts[f"bending{j + 1}_Nm"][order], color=color, ls=style, label=f"joint {j + 1}")
    ax[0].set_ylabel("bending moment [Nm]")
    ax[0].legend(fontsize=7, ncol=4, loc="upper left", bbox_to_anchor=(0.0, -0.02), frameon=False)
    for side in "AB":
        if f"F{side}_x" not in ts:
            continue
        f = np.sqrt(sum(ts[f"F{side}_{c}"]**2 for c in "xyz"))
        m = np.sqrt(sum(ts[f"M{side}_{c}"]**2 for c in "xyz"))
        ax[1].plot(az[order], f[order], label=f"|F_{side}|")
        ax[2].plot(az[order], m[order], label=f"|M_{side}|")
    ax[1].set_ylabel("clamp force [N]"); ax[2].set_ylabel("clamp moment [Nm]")
    ax[2].set_xlabel("blade azimuth [deg] (0 = downstream)")
    for a in ax:
        a.grid(True)
        a.set_xlim(0, 360)
    for a in ax[1:]:
        a.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{s['case']}: last revolution ({s['revolutions']} to periodic)")
    yield _save(fig, out, "loads_vs_azimuth.png")
    joints = result.extra["shape_joints"]                       # (3, n + 1, samples)
    fig = plt.figure(figsize=(14, 9))
    tables = {}
    for target in np.arange(0, 360, 45):
        k = int(np.argmin(np.abs(((az - target) + 180) % 360 - 180)))
        p = joints[:, :, k]
        tables[f"{target:.0f} deg"] = {"joint_x_m": p[0, :-1], "joint_y_m": p[1, :-1], "joint_z_m": p[2, :-1],
                                       "tip_m": p[:, -1]}
    _shape_axes(fig, tables)
    fig.suptitle(f"{s['case']}: the cable at 8 blade azimuths (hub frame)")
    yield _save(fig, out, "shapes_vs_azimuth.png")


def plot_envelopes(result, out: Path):
    """Fatigue: per joint against arc length, the envelope (min, mean, max) of the bending
    moment, jacket strain, torsion and axial force, and the damage per flight hour."""
    plt = _plt()
    s = result.summary
    t = result.extra["tables"]["fatigue.csv"]
    arc = np.asarray(t["arc_length_m"])
    fig, ax = plt.subplots(5, 1, figsize=(8, 12), sharex=True, constrained_layout=True)
    for a, (qty, label) in zip(ax, (("bending_Nm", "bending moment [Nm]"), ("strain", "jacket strain [-]"),
                                    ("torsion_Nm", "torsional moment [Nm]"), ("axial_N", "axial force [N]"))):
        lo, hi, mean = (np.asarray(t[f"{qty}_{k}"]) for k in ("min", "max", "mean"))
        a.fill_between(arc, lo, hi, color="tab:blue", alpha=0.25, label="min ... max")
        a.plot(arc, mean, "o-", ms=2.5, color="tab:blue", label="mean")
        a.set_ylabel(label); a.grid(True)
    ax[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))     # beside: the band stays clear
    damage = np.array([d for d in t["damage_per_hour"]], float)
    ax[4].semilogy(arc[damage > 0], damage[damage > 0], "o-", ms=2.5, color="tab:red")
    ax[4].set_ylabel("damage per flight hour [1/h]"); ax[4].grid(True, which="both", alpha=0.5)
    ax[4].set_xlabel("arc length from clamp A [m]")
    fig.suptitle(f"{s['case']}: loads along the cable and fatigue damage ({s['fatigue']['sn_quantity']} S-N curve)")
    yield _save(fig, out, "envelopes.png")


def plot_spectrum(result, out: Path):
    """A usage spectrum: the damage per flight hour at the worst point by regime, the ground-air-ground
    cycles and the start-stops (log scale), and the life at each refinement level with its
    extrapolation and error bar."""
    plt = _plt()
    sp = result.summary["spectrum"]
    if sp["life_hours"] is None:
        return
    rows = [(r["name"], r["damage_per_flight_hour"]) for r in sp["regimes"]]
    if sp["flights_per_hour"] > 0.0:
        total = sp["damage_per_flight_hour"]
        rows += [(name, sp["damage_shares"][name] * total) for name in ("ground-air-ground", "start-stops")]
    floor = sp["damage_per_flight_hour"] * 1e-6            # what is below a millionth of the total is shown at it
    fig, ax = plt.subplots(1, 2, figsize=(12, 0.8 + 0.45 * max(len(rows), 5)), constrained_layout=True,
                           gridspec_kw={"width_ratios": [3, 2]})
    y = np.arange(len(rows))
    ax[0].barh(y, [max(v, floor) for _, v in rows], color="tab:blue")
    ax[0].set_xscale("log")
    ax[0].set_yticks(y, [name for name, _ in rows])
    ax[0].invert_yaxis()
    ax[0].set_xlabel("damage per flight hour at the worst point [1/h]")
    ax[0].grid(True, axis="x")
    levels = sp["levels"]
    n = [lv["n"] for lv in levels]
    ax[1].plot(n, [lv["life_hours"] for lv in levels], "o-", label="life at n")
    if "life_extrapolated_hours" in sp:
        e, err = sp["life_extrapolated_hours"], sp["life_error_hours"]
        ax[1].axhspan(e - err, e + err, color="0.85", label="converged +- error")
        ax[1].axhline(e, color="k", ls="--", label=f"converged {e:.4g} h")
    ax[1].set_xscale("log", base=2)
    ax[1].set_xticks(n, [str(k) for k in n])
    ax[1].set_xlabel("bodies n [-]")
    ax[1].set_ylabel("life [h]")
    ax[1].grid(True)
    ax[1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{result.summary['case']}: damage over the usage spectrum at {sp['worst_point']['where']}")
    yield _save(fig, out, "spectrum.png")


def _campbell_band(values):
    """(low, high) of a two-value band in either order; None for any other count (the deck
    checks its own bands; a summary from elsewhere may not hold two values)."""
    values = [float(x) for x in np.ravel(values)] if values is not None else []
    return (min(values), max(values)) if len(values) == 2 else None


def plot_frequencies(s: dict, out: Path):
    """frequencies.png: the modes a reader needs (issue 37: it had shown 27 "modes" up to 1.7 kHz):
    with an operating speed, those below the highest rotor harmonic considered plus one, against
    the k/rev lines at that speed; without one, the lowest 12.  Undamped and damped, both labelled."""
    plt = _plt()
    fu = np.asarray(s["frequencies_hz"], float)
    fd = np.asarray(s["damped_frequencies_hz"], float)
    block = s.get("resonance") or {}
    speeds = [r for r in block.get("operating_rpm", []) if r > 0.0]
    if speeds:
        top = (block["harmonics"] + 1) * max(speeds) / 60.0
        shown = max(1, int(np.count_nonzero(fu <= top)))
    else:
        shown = min(12, fu.size)
    k = np.arange(1, shown + 1)
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.plot(k, fu[:shown], "o", label="undamped")
    ax.plot(k, np.where(fd[:shown] > 0, fd[:shown], np.nan), "x", ms=8, label="damped (judged for resonance)")
    if speeds:
        for h in range(1, block["harmonics"] + 1):
            for r in speeds:
                ax.axhline(h * r / 60.0, color="0.6", lw=0.7, ls="--", zorder=0)
            ax.text(shown + 0.35, h * speeds[0] / 60.0, f"{h}/rev", fontsize=7, va="center", color="0.35")
        ax.set_xlim(0.5, shown + 1.2)
    ax.set_ylim(0.0, 1.08 * max(float(np.max(fu[:shown])), (block.get("harmonics", 0) + 0.5) * max(speeds or [0]) / 60.0))
    ax.set_xlabel("mode [-]"); ax.set_ylabel("f [Hz]"); ax.grid(True, alpha=0.4)
    from matplotlib.ticker import MaxNLocator
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.legend(fontsize=8, loc="upper left")
    where = f", against k/rev at {', '.join(f'{r:g}' for r in speeds)} rpm" if speeds else ""
    fig.suptitle(f"{s['case']}: natural frequencies{where}")
    yield _save(fig, out, "frequencies.png")


def plot_campbell(result, out: Path):
    """Campbell diagram: tracked modes against rotor speed, the k/rev lines, the lead-lag band,
    the operating range and the crossings in it."""
    plt = _plt()
    s = result.summary
    rpm = np.asarray(s["rpm"])
    f = np.asarray(s["frequencies_hz"])
    fig, ax = plt.subplots(figsize=(9, 6), constrained_layout=True)
    op = _campbell_band(s["operating_rpm"])
    if op is not None:
        # A band along the speed axis and its edges (issue 37: shaded over the whole height, an
        # operating range as wide as the diagram had greyed the whole plot).
        ax.axvspan(*op, ymin=0.975, ymax=1.0, color="tab:green", alpha=0.6, zorder=3, label="operating range")
        for edge in op:
            if rpm[0] < edge < rpm[-1]:
                ax.axvline(edge, color="tab:green", lw=1.0, ls=":", zorder=1)
    band = _campbell_band(s["lag_band_hz"])
    if band is not None:
        ax.axhspan(*band, color="tab:orange", alpha=0.2, zorder=0, label="lead-lag band")
    top = max(float(np.max(f)) * 1.05, s["harmonics"] * rpm[-1] / 60.0 * 0.3)
    for k in range(1, s["harmonics"] + 1):
        ax.plot(rpm, k * rpm / 60.0, "k--", lw=0.7, zorder=1)
        x = 0.93 * min(rpm[-1], top * 60.0 / k)           # label inside the axes, on the line
        ax.text(x, k * x / 60.0, f"{k}/rev", fontsize=8, ha="right", va="bottom",
                bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8))
    for m in range(f.shape[1]):
        ax.plot(rpm, f[:, m], "o-", ms=2.5, lw=1.3, label=f"mode {m + 1}")
    for c in s["crossings"]:
        ax.plot(c["rpm"], c["frequency_hz"], "rx", ms=7, mew=1.5, zorder=5)
    ax.plot([], [], "rx", label="crossing in operating range")
    ax.set_xlim(rpm[0], rpm[-1]); ax.set_ylim(0, top)
    ax.set_xlabel("rotor speed [rpm]"); ax.set_ylabel("frequency [Hz]"); ax.grid(True, alpha=0.4)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"{s['case']}: Campbell diagram (rotating frame)")
    yield _save(fig, out, "campbell.png")


def spectrum_range(f, amplitude, mark: float | None = None, factor: float = 3.0, significant: float = 0.05) -> float:
    """Upper end of a spectrum plot: ``factor`` times the highest significant peak (a local
    maximum above ``significant`` of the largest one, the zero-frequency bin aside), at least
    past ``mark`` (a frequency drawn on it), and at most the Nyquist limit ``f[-1]``."""
    f, a = np.asarray(f, float), np.asarray(amplitude, float)
    nyquist = float(f[-1])
    inner = a[1:-1]
    peaks = np.flatnonzero((inner > a[:-2]) & (inner >= a[2:])) + 1
    peaks = peaks[f[peaks] > 0]
    if len(peaks) == 0:
        return nyquist
    top = float(np.max(a[peaks]))
    highest = float(np.max(f[peaks[a[peaks] >= significant * top]]))
    if mark is not None and np.isfinite(mark):
        highest = max(highest, float(mark))
    return min(nyquist, factor * highest)


def plot_result(result, out: Path) -> list[str]:
    """Plots of one run, written into the directory ``out``; returns their file names."""
    return list(_plots(result, out))


def _plots(result, out: Path):
    plt = _plt()
    s = result.summary
    if result.table is not None:
        fig = plt.figure(figsize=(14, 9))
        _shape_axes(fig, {s["case"]: _with_tip(result)}, clamped_b=s["n_constraints"] > 0)
        fig.suptitle(f"{s['case']}: the cable through its bodies' end points")
        yield _save(fig, out, "shape.png")
    if "fatigue.csv" in result.extra.get("tables", {}):
        yield from plot_envelopes(result, out)
    yield from plot_flagged_modes(result, out)
    sections = sections_of(s)
    if "revolution" in sections:
        yield from plot_flight(result, out)
        return
    if "campbell" in sections:
        yield from plot_campbell(result, out)
        return
    if "spectrum" in sections:
        yield from plot_spectrum(result, out)
        return
    if result.timeseries is not None:
        ts = result.timeseries
        fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True, constrained_layout=True)
        for name in [n for n in ts if n[:2] in ("FA", "FB") and len(n) == 4]:          # FA_x ...: the reactions
            ax[0].plot(ts["t"], ts[name], label=name)
        for name in [n for n in ts if n[:2] in ("MA", "MB") and len(n) == 4]:
            ax[1].plot(ts["t"], ts[name], label=name)
        ax[0].set_ylabel("force [N]"); ax[1].set_ylabel("moment [Nm]"); ax[1].set_xlabel("t [s]")
        for a in ax:
            # Beside the panel: inside, the legend covered FA_y and FB_y (issue 22).
            a.grid(True); a.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        fig.suptitle(f"{s['case']}: support reactions (support on chain)")
        yield _save(fig, out, "reactions.png")
    if "f_damped_hz" in s.get("decay", {}):
        from pydriver.signal import spectrum
        d = s["decay"]
        t = result.timeseries["t"]
        y = result.timeseries[d["signal"]] - result.timeseries[d["signal"]][0]
        fig, ax = plt.subplots(2, 1, figsize=(8, 6), constrained_layout=True)
        ax[0].plot(t, y * 1e3, label=d["signal"])
        ax[0].axvspan(*d["window_s"], color="0.9", label="evaluated")
        ax[0].set_xlabel("t [s]"); ax[0].set_ylabel(f"{d['signal']} - rest [mm]")
        ax[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        m = t >= d["window_s"][0]
        f, spec = spectrum(t[m], y[m])
        ax[1].plot(f, spec * 1e3, label="spectrum")
        ax[1].set_xlim(0, spectrum_range(f, spec, d["f_damped_hz"]))
        ax[1].set_xlabel("f [Hz]"); ax[1].set_ylabel("amplitude [mm]")
        ax[1].axvline(d["f_damped_hz"], color="r", ls="--", label=f"{d['f_damped_hz']:.2f} Hz")
        ax[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        for a in ax:
            a.grid(True)
        fig.suptitle(f"{s['case']}: decay test (thesis Figure 5.8)")
        yield _save(fig, out, "decay.png")
    if "frequencies_hz" in s:
        yield from plot_frequencies(s, out)


def _cm_table(table: dict, shift=None) -> dict:
    """A table of centres of mass only (the polyline through the CMs), optionally displaced."""
    p = np.column_stack([table["x_m"], table["y_m"], table["z_m"]]).astype(float)
    if shift is not None:
        p = p + shift
    return {"x_m": p[:, 0], "y_m": p[:, 1], "z_m": p[:, 2]}


def plot_flagged_modes(result, out: Path, most: int = 3):
    """The shape of each mode within the resonance margin (at most ``most``): the equilibrium
    through the centres of mass and the mode's displacement, scaled to a tenth of the cable's
    extent (a mode shape has no amplitude of its own)."""
    block = result.summary.get("resonance") or {}
    flagged = sorted({r["mode"] for r in block.get("flagged", [])})[:most]
    if "revolution" in sections_of(result.summary):        # a flight's modes are its hover state's
        table, modes = result.extra.get("hover_table"), result.extra.get("hover_modes")
    else:
        table, modes = result.table, result.extra.get("modes")
    if not flagged or table is None or modes is None:
        return
    plt = _plt()
    rest = _cm_table(table)
    p = np.column_stack([rest["x_m"], rest["y_m"], rest["z_m"]])
    extent = float(np.max(np.ptp(p, axis=0))) or 1.0
    for mode in flagged:
        i = int(np.flatnonzero(np.asarray(modes["mode"]) == mode)[0])
        n = len(rest["x_m"])
        d = np.array([[modes[f"d{c}{j + 1}"][i] for c in "xyz"] for j in range(n)], float)
        row = next(r for r in block["flagged"] if r["mode"] == mode)
        fig = plt.figure(figsize=(14, 9))
        _shape_axes(fig, {"equilibrium": rest, f"mode {mode} (scaled)": _cm_table(table, 0.1 * extent * d)},
                    clamped_b=result.summary["n_constraints"] > 0)
        fig.suptitle(f"{result.summary['case']}: mode {mode}, {row['frequency_hz']:.2f} Hz, "
                     f"{row['worst_margin_percent']:.1f} % from {row['worst_harmonic']}/rev at "
                     f"{row['operating_rpm']:g} rpm (through the centres of mass)")
        yield _save(fig, out, f"mode{mode}_shape.png")


def plot_shapes(tables: dict, path: Path, title: str):
    """Rest vs hover (or any set of) shapes in 3D and two side views, to ``path``."""
    plt = _plt()
    fig = plt.figure(figsize=(14, 9))
    _shape_axes(fig, tables)
    fig.suptitle(title)
    _save_replace(fig, path)


def plot_frequency_vs_cy(res: dict, path: Path, f_flap: float, c_cross: float):
    """First frequency against c_y (thesis Figure 5.9) with the flap frequency line."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(res["c_y"], res["f_damped_hz"], "o-", label="first damped frequency")
    ax.plot(res["c_y"], res["f_undamped_hz"], "--", label="first undamped frequency")
    ax.axhline(f_flap, color="r", ls=":", label=f"flap frequency {f_flap} Hz")
    ax.axvline(c_cross, color="k", ls=":", label=f"c_y = {c_cross:.2f} Nm/rad")
    ax.set_xlabel("c_y [Nm/rad]"); ax.set_ylabel("f [Hz]"); ax.grid(True); ax.legend()
    fig.suptitle("UH-60 cable part 2: first frequency against c_y (thesis Figure 5.9)")
    _save_replace(fig, path)


def caption(name: str, summary: dict) -> str:
    """What the figure ``name`` (a file plot_result writes) shows, for report.html."""
    import re
    s = summary
    mode = re.fullmatch(r"mode(\d+)_shape\.png", name)
    if mode:
        return (f"Mode {mode.group(1)}, within the resonance margin: the equilibrium through the centres of mass "
                "and the mode's displacement (scaled to a tenth of the cable's extent; a mode has no amplitude "
                "of its own), in a 3-D view to scale and the y-z and x-y side views [m].")
    where = "at the end of the run" if "time series" in sections_of(s) else "at the static equilibrium"
    decay = s.get("decay", {})
    captions = {
        "shape.png": f"The cable {where} through its bodies' end points: a 3-D view to scale and the y-z and x-y "
                     "side views [m]; clamp A is the square, clamp B the triangle.",
        "envelopes.png": "Loads along the cable from clamp A (arc length 0): at every joint the minimum, mean and "
                         "maximum over the record of the bending moment, jacket strain, torsional moment and axial "
                         "force, and the fatigue damage per flight hour (log scale; its peaks are the hotspots).",
        "loads_vs_azimuth.png": "Over the last, periodic revolution against the blade azimuth: the bending moment "
                                "at up to eight joints along the cable (the most loaded among them), and the "
                                "magnitudes of the clamp forces and moments at A and B.",
        "shapes_vs_azimuth.png": "The cable in the hub frame at eight blade azimuths, 45 deg apart, over the last "
                                 "revolution: a 3-D view to scale and the y-z and x-y side views [m].",
        "campbell.png": "Campbell diagram: the tracked natural frequencies against rotor speed (rotating frame), "
                        "the k/rev lines, the lead-lag band, the operating range, and the crossings in it (x).",
        "reactions.png": "Support reactions against time: the force (top) and moment (bottom) components that each "
                         "support exerts on the cable.",
        "decay.png": f"Decay test: the displacement of {decay.get('signal', 'the signal')} from rest after the force "
                     "pulse (top; the shaded window is evaluated), and its amplitude spectrum (bottom, up to three "
                     "times its highest significant peak) with the damped frequency from the zero crossings "
                     "(dashed).",
        "frequencies.png": "Natural frequencies of the modes about the equilibrium, undamped (o) and damped (x), "
                           "on a log scale.",
        "spectrum.png": "Usage spectrum: the damage per flight hour at the worst jacket point from each regime "
                        "(its share of the flight time times its damage per hour there), from the ground-air-ground "
                        "cycles and from the rotor's start-stops, on a log scale (below a millionth of the total: "
                        "drawn at it); and the life at each number of bodies n with its extrapolation and error bar.",
    }
    return captions.get(name, name)
