"""A GIF of one life: the track, the learner's path so far, and every vehicle's body."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

from enn_traffic.geometry import body_polygon  # noqa: E402


def animate_run(world, poses: np.ndarray, out: str | Path, title: str = "",
                frames: int = 150) -> None:
    """``poses`` (n, V, 3): vehicle 0 is the learner (red), the others grey."""
    vehicle = world.scenario.vehicle
    figure, axes = plt.subplots(figsize=(5, 5))
    for x1, y1, x2, y2 in world.track.walls:
        axes.plot([x1, x2], [y1, y2], color="black", lw=0.8)
    axes.set_aspect("equal")
    axes.set_title(title, fontsize=9)
    (line,) = axes.plot([], [], color="C0", lw=1)
    bodies = [Polygon(np.zeros((4, 2)), closed=True, color="C3" if v == 0 else "0.5")
              for v in range(poses.shape[1])]
    for body in bodies:
        axes.add_patch(body)
    indices = np.unique(np.linspace(0, len(poses) - 1, min(frames, len(poses))).astype(int))

    def draw(k):
        i = indices[k]
        line.set_data(poses[: i + 1, 0, 0], poses[: i + 1, 0, 1])
        for v, body in enumerate(bodies):
            body.set_xy(body_polygon(*poses[i, v], vehicle.length, vehicle.width))
        return (line, *bodies)

    animation = FuncAnimation(figure, draw, frames=len(indices), blit=True)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    animation.save(str(out), writer=PillowWriter(fps=15))
    plt.close(figure)
