"""Learning curves and trajectory pictures (matplotlib, headless)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from enn_traffic.io import write_atomic  # noqa: E402


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
    for x1, y1, x2, y2 in walls:
        axes.plot([x1, x2], [y1, y2], color="black", lw=0.8)
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
