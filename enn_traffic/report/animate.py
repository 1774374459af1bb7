"""A GIF of one life: the roads around the learner, its path so far, and every vehicle's body;
or of a crowd, every learner at once among SUMO's vehicles (:func:`animate_crowd`).

A track that fits in :data:`FOLLOW_M` metres is shown whole and still. On a larger map (a
city) the view is :data:`FOLLOW_M` metres wide and follows the learner, so that it and the
vehicles near it can be seen; only the walls and bodies near the view are drawn.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from tqdm import tqdm  # noqa: E402

from enn_traffic.core.errors import InputError  # noqa: E402
from enn_traffic.core.geometry import body_polygon  # noqa: E402
from enn_traffic.core.progress import terminal  # noqa: E402
from enn_traffic.report.plots import segments_within, square_view  # noqa: E402

FRAMES = 150  # at most, spread evenly over the life
CROWD_FRAMES = 100  # a crowd's frames draw every learner and vehicle: fewer, to write in seconds
FPS = 15
FOLLOW_M = 150.0  # a larger map is shown this wide around the learner


def animate_run(world, poses: np.ndarray, out: str | Path, title: str = "",
                frames: int = FRAMES, progress: bool = True,
                sumo_start: float | None = None) -> None:
    """``poses`` (n, V, 3): vehicle 0 is the learner (red), the others grey (NaN: not on the
    network at that step). Each frame shows the learner's time and step, and with
    ``sumo_start`` (the SUMO time at the learner's start) SUMO's time."""
    vehicle = world.scenario.vehicle
    path = poses[:, 0, :2]
    low, high = square_view(path, FOLLOW_M / 2, world.track.walls)
    follow = high[0] - low[0] > FOLLOW_M + 1e-9
    figure, axes = plt.subplots(figsize=(5, 5))
    near = square_view(path, FOLLOW_M, None) if follow else (low, high)
    axes.add_collection(LineCollection(segments_within(world.track.walls, *near),
                                       colors="black", linewidths=0.8))
    axes.set_aspect("equal")
    if follow:
        axes.set_xticks([])
        axes.set_yticks([])
        title += f" (view {FOLLOW_M:g} m wide, following the learner)"
    else:
        axes.set_xlim(low[0], high[0])
        axes.set_ylim(low[1], high[1])
    axes.set_title("\n".join(textwrap.wrap(title, 60)), fontsize=9)
    figure.tight_layout()
    (line,) = axes.plot([], [], color="C0", lw=1.2, zorder=3)
    clock = axes.text(0.02, 0.98, "", transform=axes.transAxes, va="top", fontsize=8, zorder=5,
                      bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.6"})
    traffic = PolyCollection([], facecolors="0.45", edgecolors="0.25", linewidths=0.4,
                             zorder=2)
    learner = PolyCollection([], facecolors="C3", edgecolors="black", linewidths=0.6,
                             zorder=4)
    axes.add_collection(traffic)
    axes.add_collection(learner)
    indices = np.unique(np.linspace(0, len(poses) - 1, min(frames, len(poses))).astype(int))
    reach = np.hypot(vehicle.length, vehicle.width)

    def draw(k):
        i = indices[k]
        view_low, view_high = low, high
        if follow:
            view_low, view_high = path[i] - FOLLOW_M / 2, path[i] + FOLLOW_M / 2
            axes.set_xlim(view_low[0], view_high[0])
            axes.set_ylim(view_low[1], view_high[1])
        line.set_data(path[: i + 1, 0], path[: i + 1, 1])
        learner.set_verts([body_polygon(*poses[i, 0], vehicle.length, vehicle.width)])
        others = poses[i, 1:]
        shown = others[~np.isnan(others[:, 0])
                       & (others[:, :2] >= view_low - reach).all(1)
                       & (others[:, :2] <= view_high + reach).all(1)]
        traffic.set_verts([body_polygon(*pose, vehicle.length, vehicle.width)
                           for pose in shown])
        clock.set_text(f"t = {i * vehicle.dt:.1f} s, step {i}" + (
            "" if sumo_start is None else f"\nSUMO time {sumo_start + i * vehicle.dt:.1f} s"))
        return line, traffic, learner, clock

    animation = FuncAnimation(figure, draw, frames=len(indices), blit=not follow)
    _save(animation, figure, out, len(indices), progress)


def _save(animation: FuncAnimation, figure, out: str | Path, frames: int,
          progress: bool) -> None:
    """Write ``animation``'s ``frames`` as the GIF ``out``, whole or not at all."""
    out = Path(out)
    partial = out.with_name(f".{out.stem}.tmp{out.suffix}")  # whole or not at all, as write_atomic
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with tqdm(file=terminal(), total=frames, desc=f"{out.name}: frames", unit="frame",
                  disable=not progress, leave=False) as bar:
            animation.save(str(partial), writer=PillowWriter(fps=FPS),
                           progress_callback=lambda *_: bar.update(1))
        os.replace(partial, out)
    except OSError as exc:
        raise InputError(f"cannot write: {exc.strerror or exc}", out) from None
    finally:  # also on Ctrl-C: no half-written GIF left beside the user's files
        partial.unlink(missing_ok=True)
        plt.close(figure)


def animate_crowd(walls: np.ndarray, learners: np.ndarray, traffic: list[np.ndarray],
                  out: str | Path, title: str, dt: float, frames: int = CROWD_FRAMES,
                  progress: bool = True) -> None:
    """Every learner at once (red dots) among SUMO's vehicles (grey dots): ``learners``
    (n, K, 2) their centres at each step (NaN: not on the network), ``traffic`` the SUMO
    vehicles' centres (m, 2) at each step. The view holds every learner's path; only the
    walls in it are drawn."""
    seen = learners[np.isfinite(learners).all(axis=2)]
    if not len(seen):
        raise ValueError("no learner was on the network")
    margin = 20.0
    low, high = seen.min(axis=0) - margin, seen.max(axis=0) + margin
    figure, axes = plt.subplots(figsize=(5, 5))
    axes.add_collection(LineCollection(segments_within(walls, low, high), colors="0.3",
                                       linewidths=0.3))
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_aspect("equal")
    axes.set_xticks([])
    axes.set_yticks([])
    axes.set_title("\n".join(textwrap.wrap(title, 70)), fontsize=9)
    figure.tight_layout()
    others = axes.scatter([], [], s=4, color="0.45", zorder=2, label="SUMO's vehicles")
    own = axes.scatter([], [], s=7, color="C3", zorder=3, label="learners")
    axes.legend(loc="lower right", fontsize=7)
    clock = axes.text(0.02, 0.98, "", transform=axes.transAxes, va="top", fontsize=8, zorder=5,
                      bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.6"})
    indices = np.unique(np.linspace(0, len(learners) - 1, min(frames, len(learners))).astype(int))

    def draw(k):
        i = indices[k]
        own.set_offsets(learners[i][np.isfinite(learners[i]).all(axis=1)])
        others.set_offsets(traffic[i].reshape(-1, 2))
        clock.set_text(f"t = {i * dt:.1f} s")
        return others, own, clock

    animation = FuncAnimation(figure, draw, frames=len(indices), blit=True)
    _save(animation, figure, out, len(indices), progress)
