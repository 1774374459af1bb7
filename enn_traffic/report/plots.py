"""Learning curves and trajectory pictures (matplotlib, headless)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from enn_traffic.core.io import write_atomic  # noqa: E402


def save_figure(figure, path: str | Path) -> None:
    suffix = Path(path).suffix.lstrip(".") or "png"
    write_atomic(path, lambda handle: figure.savefig(handle, format=suffix, dpi=120), binary=True)
    plt.close(figure)


def learning_curve(table: pd.DataFrame, path: str | Path, title: str = "") -> None:
    """Best, mean and median fitness per generation of one run."""
    figure, axes = plt.subplots(figsize=(6, 3.6))
    axes.plot(table["generation"], table["best_fitness"], label="best", color="C3")
    axes.plot(table["generation"], table["mean_fitness"], label="mean", color="C0")
    axes.plot(table["generation"], table["median_fitness"], label="median", color="C0", ls=":")
    axes.set_xlabel("generation")
    axes.set_ylabel("fitness [steps survived]")
    axes.set_title(title)
    axes.legend()
    axes.grid(alpha=0.3)
    figure.tight_layout()
    save_figure(figure, path)


def heat_map(matrix: pd.DataFrame, path: str | Path, title: str, label: str) -> None:
    """A matrix (rows by columns, e.g. controllers by scenarios) as colours, each cell with its
    value written in it."""
    rows, columns = matrix.shape
    figure, ax = plt.subplots(figsize=(2.2 + 1.1 * columns, 1.6 + 0.45 * rows))
    values = matrix.to_numpy(dtype=float)
    image = ax.imshow(values, cmap="viridis", aspect="auto")
    middle = (np.nanmin(values) + np.nanmax(values)) / 2
    ax.set_xticks(range(columns), [str(c) for c in matrix.columns], rotation=30, ha="right",
                  fontsize=8)
    ax.set_yticks(range(rows), [str(r) for r in matrix.index], fontsize=8)
    for i in range(rows):
        for j in range(columns):
            if np.isnan(values[i, j]):
                continue
            ax.text(j, i, f"{values[i, j]:.0f}", ha="center", va="center", fontsize=8,
                    color="black" if values[i, j] > middle else "white")
    figure.colorbar(image, label=label)
    ax.set_title(title, fontsize=9)
    figure.tight_layout()
    save_figure(figure, path)


def learning_curves(
    runs: dict[str, pd.DataFrame],
    path: str | Path | None,
    title: str = "",
    hline: float | None = None,
    log: bool = False,
    axes=None,
) -> None:
    """Best fitness per generation of several runs on one plot."""
    own = axes is None
    if own:
        figure, axes = plt.subplots(figsize=(6.4, 3.8))
    for label, table in runs.items():
        axes.plot(table["generation"], table["best_fitness"], label=label, lw=1.4)
    if hline is not None:
        axes.axhline(hline, color="grey", ls="--", lw=0.8)
    if log:
        axes.set_yscale("log")
    axes.set_xlabel("generation")
    axes.set_ylabel("best fitness [steps]")
    axes.set_title(title)
    axes.legend(fontsize=8)
    axes.grid(alpha=0.3)
    if own:
        figure.tight_layout()
        save_figure(figure, path)


def break_at_jumps(xy: np.ndarray, jump: float = 5.0) -> np.ndarray:
    """``xy`` with a NaN row wherever consecutive points lie more than ``jump`` apart (a
    respawn), so a line plot does not draw the jump."""
    gaps = np.flatnonzero(np.hypot(*np.diff(xy, axis=0).T) > jump) + 1
    return np.insert(xy.astype(float), gaps, np.nan, axis=0)


def draw_paths(axes, walls: np.ndarray, paths: Sequence[np.ndarray], labels=None,
               colors=None, start=None, width: float = 1.0) -> None:
    """Walls in black and each path (n, 2+) as a line broken at respawns, ending in an x (red,
    or the path's own colour when ``colors`` are given)."""
    from matplotlib.collections import LineCollection

    walls = np.asarray(walls, dtype=float).reshape(-1, 4)
    # one artist for every wall: a city's thousands of Line2D took seconds to build and draw
    axes.add_collection(LineCollection(walls.reshape(-1, 2, 2), colors="black", linewidths=0.8))
    if len(walls):
        axes.update_datalim(walls.reshape(-1, 2))
        axes.autoscale_view()
    for index, poses in enumerate(paths):
        xy = break_at_jumps(poses[:, :2])
        axes.plot(xy[:, 0], xy[:, 1], lw=width, label=labels[index] if labels else None,
                  color=colors[index] if colors else None)
        axes.plot(poses[-1, 0], poses[-1, 1], "x", color=colors[index] if colors else "C3")
    if start is not None:
        axes.plot(start[0], start[1], "o", color="C2", label="start")
    axes.set_aspect("equal")


def trajectories(
    walls: np.ndarray,
    paths: Sequence[np.ndarray],
    path: str | Path,
    title: str = "",
    labels: Sequence[str | None] | None = None,
    start: tuple[float, float, float] | None = None,
    colors: Sequence[str] | None = None,
) -> None:
    """Walls in black and each trajectory (n, 2+) as a coloured line, broken at respawns."""
    figure, axes = plt.subplots(figsize=(6.4, 6.4))
    draw_paths(axes, walls, paths, labels=labels, colors=colors, start=start)
    axes.set_title(title)
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    if labels or start is not None:
        axes.legend(fontsize=8, loc="best")
    figure.tight_layout()
    save_figure(figure, path)


def square_view(path: np.ndarray, margin: float, walls: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """The corners (low, high) of a square view of ``path`` (n, 2; NaN rows skipped) and
    ``margin`` metres around it, cut to the walls' bounding box when ``walls`` are given (a
    small track is shown whole, a city around the path)."""
    low = np.nanmin(path, axis=0) - margin
    high = np.nanmax(path, axis=0) + margin
    if walls is not None and len(walls):
        points = walls.reshape(-1, 2)
        low, high = np.maximum(low, points.min(0) - 1.0), np.minimum(high, points.max(0) + 1.0)
    centre, half = (low + high) / 2, max(*(high - low), 2 * margin) / 2
    return centre - half, centre + half  # square, so the picture has no bands


def segments_within(segments: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The segments (S, 4: x1, y1, x2, y2) whose bounding boxes meet the view (low, high), as
    (s, 2, 2) for a ``LineCollection``."""
    xs, ys = segments[:, [0, 2]], segments[:, [1, 3]]
    keep = ((xs.max(1) >= low[0]) & (xs.min(1) <= high[0])
            & (ys.max(1) >= low[1]) & (ys.min(1) <= high[1]))
    return segments[keep].reshape(-1, 2, 2)


COLLISION_VIEW_M = 24.0  # the side of the inset that shows a collision up close


def _collision_inset(axes, learner: np.ndarray, hit_body: np.ndarray,
                     learner_body: np.ndarray | None) -> None:
    """An inset in ``axes``' upper left: the collision up close (:data:`COLLISION_VIEW_M`
    across, round the vehicle ``hit_body`` ran into), the learner's last metres of path (its
    front's) and its body at the end (``learner_body``), the vehicle's body, which on a
    city's scale lies under the end marker."""
    from matplotlib.patches import Polygon as Patch

    centre = hit_body.mean(axis=0)
    inset = axes.inset_axes((0.02, 0.62, 0.36, 0.36))
    inset.add_patch(Patch(hit_body, closed=True, facecolor="C1", edgecolor="black",
                          alpha=0.85, zorder=2))
    if learner_body is not None:
        inset.add_patch(Patch(learner_body, closed=True, facecolor="none", edgecolor="C3",
                              lw=1.5, zorder=3))
    near = np.abs(learner - centre).max(axis=1) <= COLLISION_VIEW_M
    inset.plot(*break_at_jumps(learner[near]).T, color="C3", lw=2.2, zorder=3)
    inset.plot(*learner[-1], "x", color="C3", ms=9, mew=2.0, zorder=4)
    half = COLLISION_VIEW_M / 2
    inset.set_xlim(centre[0] - half, centre[0] + half)
    inset.set_ylim(centre[1] - half, centre[1] + half)
    inset.set_aspect("equal")
    inset.set_xticks([])
    inset.set_yticks([])
    inset.set_title(f"the collision, {COLLISION_VIEW_M:g} m across", fontsize=7)
    axes.indicate_inset_zoom(inset, edgecolor="0.3")


def learner_among_traffic(walls: np.ndarray, exits: np.ndarray, poses: np.ndarray,
                          path: str | Path, title: str, end_label: str,
                          hit_body: np.ndarray | None = None, margin: float = 50.0,
                          learner_body: np.ndarray | None = None) -> None:
    """One life among SUMO's traffic, drawn so that the learner stands out on a busy map: the
    view cropped to the learner's path and ``margin`` metres around it; the walls and exits
    there; every vehicle's path in light grey under the learner's, and where it was last seen;
    the learner's path on top, its start and its end (``end_label``), and the body of the
    vehicle it ran into (corners ``hit_body``), with the learner's at the end
    (``learner_body``) up close in an inset."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Polygon as Patch

    learner = poses[:, 0, :2]
    low, high = square_view(learner, margin)
    figure, axes = plt.subplots(figsize=(7.2, 7.2))
    axes.add_collection(LineCollection(segments_within(walls, low, high), colors="black",
                                       linewidths=0.8, label="walls (edge of the road surface)",
                                       zorder=2))
    exits_here = segments_within(exits.reshape(-1, 4), low, high)
    if len(exits_here):
        axes.add_collection(LineCollection(exits_here, colors="C2", linewidths=2.0,
                                           label="exits (the network's fringe)", zorder=2))
    shown = False
    for column in range(1, poses.shape[1]):
        xy = poses[:, column, :2]
        seen = ~np.isnan(xy[:, 0])
        inside = seen & (xy >= low).all(1) & (xy <= high).all(1)
        if not inside.any():
            continue
        axes.plot(*break_at_jumps(xy[seen]).T, color="0.65", lw=0.7, zorder=1,
                  label=None if shown else "SUMO vehicles' paths")
        last = xy[seen][-1]
        axes.plot(*last, ".", color="0.45", ms=4, zorder=1,
                  label=None if shown else "where each was last seen")
        shown = True
    if hit_body is not None:
        axes.add_patch(Patch(hit_body, closed=True, facecolor="C1", edgecolor="black",
                             alpha=0.85, zorder=7, label="the vehicle it ran into"))
    axes.plot(*break_at_jumps(learner).T, color="C3", lw=2.2, zorder=5, label="learner's path")
    axes.plot(*learner[0], "o", color="C2", ms=8, zorder=6, label="learner's start")
    axes.plot(*learner[-1], "X", color="C3", mec="black", ms=11, zorder=6, label=end_label)
    if hit_body is not None:
        _collision_inset(axes, learner, hit_body, learner_body)
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_aspect("equal")
    axes.set_title(title)
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    axes.legend(fontsize=8, loc="best", framealpha=0.9)
    figure.tight_layout()
    save_figure(figure, path)


LABEL_OFFSETS_PT = [(0.0, 0.0)] + [
    (radius * np.cos(angle), radius * np.sin(angle))
    for radius in range(14, 420, 14) for angle in np.linspace(0, 2 * np.pi, 16, endpoint=False)]


def _rank_labels(figure, axes, anchors: list[np.ndarray]) -> None:
    """Number the ``anchors`` (data coordinates) 1, 2, ... in ``axes``, each label where it
    overlaps no earlier one: at its anchor, or at the first of :data:`LABEL_OFFSETS_PT`
    (rings around it) where it is free, with a line back to its anchor. Label 1 is boxed in
    the lanes' colour."""
    from matplotlib.transforms import Bbox

    renderer = figure.canvas.get_renderer()
    points = figure.dpi / 72.0
    placed: list[Bbox] = []
    for rank, anchor in enumerate(anchors, start=1):
        first = rank == 1
        style = {"color": "white" if first else "C3", "fontsize": 9, "fontweight": "bold",
                 "zorder": 5, "ha": "center", "va": "center",
                 "bbox": {"boxstyle": "round,pad=0.15", "fc": "C3" if first else "white",
                          "ec": "C3", "lw": 0.6, "alpha": 1.0 if first else 0.85}}
        probe = axes.text(*anchor, f"{rank}", **style)
        size = probe.get_window_extent(renderer)
        probe.remove()
        pad = 2 * (0.15 * 9 + 1) * points  # the box's pad round the text, and a point more
        width, height = size.width + pad, size.height + pad
        x, y = axes.transData.transform(anchor)
        for dx, dy in LABEL_OFFSETS_PT:
            box = Bbox.from_bounds(x + dx * points - width / 2, y + dy * points - height / 2,
                                   width, height)
            if not any(box.overlaps(other) for other in placed):
                break
        placed.append(box)
        arrow = {} if (dx, dy) == (0.0, 0.0) else {
            "arrowprops": {"arrowstyle": "-", "color": "C3", "lw": 0.6, "shrinkA": 0,
                           "shrinkB": 0}}
        axes.annotate(f"{rank}", xy=anchor, xytext=(dx, dy), textcoords="offset points",
                      **style, **arrow)


def road_surfaces(surfaces: dict[str, tuple[object, np.ndarray]],
                  lanes: list[tuple[str, np.ndarray]], path: str | Path, title: str) -> None:
    """The network's road surface one way and another, side by side: for each ``surfaces``
    entry (label: (area, walls)) the area in grey and its walls in black; on the last, the
    ``lanes`` (id, centre line (n, 2)) numbered in their order, the start lanes to choose,
    listed under the panels. Every panel shows the last surface's extent (the cars' road: a
    railway or a ship lane beyond it does not shrink the city), its lines thinner on a
    larger network."""
    import textwrap

    from matplotlib.collections import LineCollection

    last_area = list(surfaces.values())[-1][0]
    x0, y0, x1, y1 = last_area.bounds
    margin = 0.02 * max(x1 - x0, y1 - y0, 1.0)
    aspect = (y1 - y0 + 2 * margin) / max(x1 - x0 + 2 * margin, 1.0)
    width = 7.0
    figure, axes_row = plt.subplots(1, len(surfaces), sharex=True, sharey=True, squeeze=False,
                                    figsize=(width * len(surfaces),
                                             min(max(width * aspect, 4.0), 12.0) + 1.2))
    line = float(np.clip(600.0 / max(x1 - x0, y1 - y0, 1.0), 0.15, 0.7))
    for axes, (label, (area, walls)) in zip(axes_row[0], surfaces.items(), strict=True):
        for polygon in getattr(area, "geoms", [area]):
            axes.fill(*polygon.exterior.xy, color="0.85", lw=0)
            for hole in polygon.interiors:
                axes.fill(*hole.xy, color="white", lw=0)
        axes.add_collection(LineCollection(walls.reshape(-1, 2, 2), colors="black",
                                           linewidths=line))
        axes.set_title("\n".join(textwrap.wrap(f"{label}: {len(walls):,} walls", 48)),
                       fontsize=10)
        axes.set_aspect("equal")
        axes.set_xlim(x0 - margin, x1 + margin)
        axes.set_ylim(y0 - margin, y1 + margin)
        axes.set_xlabel("x [m]")
    axes_row[0, 0].set_ylabel("y [m]")
    last = axes_row[0, -1]
    anchors = []
    for _, shape in lanes:
        last.plot(*shape.T, color="C3", lw=max(2 * line, 1.2), zorder=3)
        last.annotate("", xy=shape[-1], xytext=shape[-2], zorder=3,
                      arrowprops={"arrowstyle": "->", "color": "C3", "lw": 1.2})
        steps = np.hypot(*np.diff(shape, axis=0).T)
        halfway = int(np.searchsorted(np.cumsum(steps), steps.sum() / 2))
        anchors.append(shape[halfway] + (shape[halfway + 1] - shape[halfway]) * 0.5)
    caption = 0.0  # the figure's height the caption under the panels takes
    if lanes:
        listed = ("start lanes, by the demand over them (1, boxed: the start_lane = \"auto\" "
                  "choice): " + ", ".join(f"{rank} {lane}"
                                          for rank, (lane, _) in enumerate(lanes, 1)))
        wrapped = textwrap.wrap(listed, 60 * len(surfaces))
        figure.text(0.5, 0.01, "\n".join(wrapped), ha="center", va="bottom", fontsize=8,
                    color="C3")
        caption = (len(wrapped) * 8 * 1.3 + 6) / 72 / figure.get_figheight()
    figure.suptitle(title, fontsize=11)
    figure.tight_layout(rect=(0, caption, 1, 1))
    _rank_labels(figure, last, anchors)
    save_figure(figure, path)
