"""SUMO's own step time with learners moved in it, as the closed loop moves them: what
``enn-traffic bench --only sumo_step`` measures, kept here because it drives libsumo itself."""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import libsumo

from enn_traffic.sumo.command import output_prefix
from enn_traffic.sumo.learners import add_learner, learner_id, move_learner
from enn_traffic.sumo.ssm import ssm_options


def step_seconds(source: list[str], learners: int, steps: int, warmup_steps: int
                 ) -> tuple[float, int, int]:
    """Seconds per SUMO step (moving the learners included) after ``warmup_steps`` steps of
    0.1 s, of SUMO started on ``source`` (``["-c", "city.sumocfg"]``, or a network and route
    files), with ``learners`` learners in SUMO as the closed loop puts them there
    (:func:`~enn_traffic.sumo.learners.add_learner`, SSM devices, each moved along a lane of
    its own at 10 m/s by :func:`~enn_traffic.sumo.learners.move_learner`). Also the network's
    lanes (internal lanes excepted) and the vehicles on it when the timing starts."""
    with tempfile.TemporaryDirectory(prefix="enn-bench-sumo-") as folder:
        libsumo.start(["sumo", *source, "--seed", "1", "--step-length", "0.1",
                       "--no-step-log", "true", "--no-warnings", "true", "--verbose", "false",
                       "--duration-log.statistics", "false", "--gui-settings-file", "",
                       "--collision.action", "none", "--output-prefix", output_prefix(Path(folder)),
                       *ssm_options(tuple(learner_id(k) for k in range(learners)))])
        try:
            for _ in range(warmup_steps):
                libsumo.simulationStep()
            lanes = sorted(lane for lane in libsumo.lane.getIDList()
                           if not lane.startswith(":") and libsumo.lane.getLength(lane) > 60
                           and (not libsumo.lane.getAllowed(lane)  # every class
                                or "passenger" in libsumo.lane.getAllowed(lane)))
            paths = []
            for k in range(learners):
                lane = lanes[k * len(lanes) // max(learners, 1)]
                edge, index = lane.rsplit("_", 1)
                paths.append((edge, int(index), libsumo.lane.getLength(lane)))
                add_learner(4.3, 1.7, 10.0, learner_id(k))
            vehicles = libsumo.vehicle.getIDCount() - learners
            started = time.perf_counter()
            for t in range(steps):
                for k, (edge, index, length) in enumerate(paths):
                    along = 1.0 + t % (length - 2.0)  # back and forth along the lane
                    x, y = libsumo.simulation.convert2D(edge, along, index)
                    ahead = libsumo.simulation.convert2D(edge, along + 1.0, index)
                    move_learner(x, y, math.atan2(ahead[1] - y, ahead[0] - x), learner_id(k))
                libsumo.simulationStep()
            seconds = (time.perf_counter() - started) / steps
            lanes = sum(not lane.startswith(":") for lane in libsumo.lane.getIDList())
            return seconds, lanes, vehicles
        finally:
            libsumo.close()
