"""Where the diagnosis figure's legends and panel 1's zoom go (issue 26), once the figure is laid out.

A legend at a fixed corner covered the red "largest miss" label on after_001; one at matplotlib's "best" covered the
steep middle of a thin M130-27s loop (its few samples there are few vertices). Here every candidate place is scored
on the figure as drawn: the texts and the largest-miss marks (gid :data:`MISS`) it would cover, then how much of the
plotted curves (points every 3 pixels along each line, and the scatter's points), then a fixed order. Deterministic:
the same figure, the same places, the same PNG bytes.
"""

from __future__ import annotations

import numpy as np

MISS = "largest_miss"  # gid of the largest miss's circle and label: no legend or inset may cover them
LOCS = ("lower left", "lower right", "upper left", "upper right", "center left", "center right", "lower center",
        "upper center", "center")
# the inset's lower-left corners (axes fraction): on the left far enough in that its tick labels stay off the
# axes' own, low enough at the bottom for its own x tick labels
CORNERS = ((0.10, 0.64), (0.65, 0.08), (0.65, 0.64), (0.10, 0.08))
INSET = 0.32  # its width and height (axes fraction)
LABELS_PX = (24, 14, 12)  # room for the inset's y tick labels (left), x tick labels (below) and title (above), pixels


def along(D: np.ndarray, step: float = 3.0) -> np.ndarray:
    """Points every ``step`` pixels along a polyline (display coordinates; NaN rows dropped): a legend over a steep
    stretch with few samples covers as much of the curve as over a dense one."""
    D = D[np.isfinite(D).all(axis=1)]
    if len(D) < 2:
        return D
    t = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(D, axis=0).T))])
    u = np.arange(0.0, t[-1] + step, step)
    return np.column_stack([np.interp(u, t, D[:, 0]), np.interp(u, t, D[:, 1])])


def points(ax) -> np.ndarray:
    """Display coordinates of what ``ax`` plots: points along its lines, its scatter points."""
    pts = [along(ln.get_transform().transform(np.column_stack(ln.get_data()).astype(float)))
           for ln in ax.lines if len(ln.get_xdata()) > 1 and ln.get_visible() and ln.get_linestyle() != "None"]
    pts += [c.get_offset_transform().transform(c.get_offsets()) for c in ax.collections if len(c.get_offsets())]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _inside(P: np.ndarray, bb) -> int:
    return int(np.sum((P[:, 0] >= bb.x0) & (P[:, 0] <= bb.x1) & (P[:, 1] >= bb.y0) & (P[:, 1] <= bb.y1)))


def _avoid(ax, renderer) -> list:
    out = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
    out += [ln.get_window_extent(renderer) for ln in ax.lines if ln.get_gid() == MISS]
    return out + [c.get_tightbbox(renderer) for c in ax.child_axes]


def place_legend(ax, renderer) -> None:
    """Move ``ax``'s legend to the place of :data:`LOCS` that covers the fewest texts, largest-miss marks and insets,
    then the fewest plotted points (module docstring)."""
    leg = ax.get_legend()
    if leg is None:
        return
    avoid, P, best = _avoid(ax, renderer), points(ax), None
    for j, loc in enumerate(LOCS):
        leg.set_loc(loc)
        bb = leg.get_window_extent(renderer)
        key = (sum(bool(bb.overlaps(a)) for a in avoid), _inside(P, bb), j)
        best = key if best is None or key < best else best
    leg.set_loc(LOCS[best[2]])


def zoom_inset(ax, renderer, xr: tuple, yr: tuple):
    """An inset of ``ax`` showing the window ``xr`` x ``yr`` (data units) with a copy of every line and scatter of
    ``ax``, in the corner of :data:`CORNERS` that covers the fewest marks and plotted points; the window marked in
    ``ax``. Returns the inset Axes."""
    avoid, P, best = _avoid(ax, renderer), points(ax), None
    to_disp = ax.transAxes.transform
    from matplotlib.transforms import Bbox

    for j, (cx, cy) in enumerate(CORNERS):
        (a, b), (c, e) = to_disp([(cx, cy), (cx + INSET, cy + INSET)])
        bb = Bbox([[a - LABELS_PX[0], b - LABELS_PX[1]], [c, e + LABELS_PX[2]]])  # with its tick labels and title
        key = (sum(bool(bb.overlaps(a)) for a in avoid), _inside(P, bb), j)
        best = key if best is None or key < best else best
    cx, cy = CORNERS[best[2]]
    ins = ax.inset_axes([cx, cy, INSET, INSET])
    for ln in ax.lines:
        if len(ln.get_xdata()):
            ins.plot(ln.get_xdata(), ln.get_ydata(), ls=ln.get_linestyle(), color=ln.get_color(),
                     lw=ln.get_linewidth(), marker=ln.get_marker(), ms=ln.get_markersize(),
                     mfc=ln.get_markerfacecolor(), mec=ln.get_markeredgecolor(), mew=ln.get_markeredgewidth(),
                     zorder=ln.get_zorder())
    for c in ax.collections:
        ins.scatter(*np.asarray(c.get_offsets()).T, s=c.get_sizes(), c=c.get_facecolors(),
                    edgecolors=c.get_edgecolors(), linewidths=c.get_linewidths(), zorder=c.get_zorder())
    ins.set_xlim(*xr)
    ins.set_ylim(*yr)
    ins.tick_params(labelsize=5.5, length=2, pad=1)
    ins.set_title("zoom: the largest miss", fontsize=6, pad=2)
    ax.indicate_inset_zoom(ins, edgecolor="0.35", lw=0.8)
    return ins
