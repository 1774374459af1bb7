"""SUMO's own step time with learners moved in it, as the closed loop moves them (what
``enn-traffic bench --only sumo_step`` measures), and SUMO-driven vehicles added to a running
SUMO (``bench --only crowd_marginal``): kept here because they drive libsumo themselves."""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import libsumo

from enn_traffic.roads.xmlread import parse_root
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
                       *ssm_options()])
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
                add_learner(4.3, 1.7, 10.0, learner_id(k), ssm_device=True)
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


ADDED = "bench_added_"  # the SUMO ids of the added SUMO-driven vehicles


def trip_ends(trips: Path, after_s: float, count: int) -> list[tuple[str, str]]:
    """``count`` (from, to) edge pairs of the trips that depart after ``after_s`` (cycled)."""
    pairs = [(e.get("from"), e.get("to")) for e in parse_root(trips)
             if e.tag == "trip" and float(e.get("depart", "0")) > after_s]
    return [pairs[i % len(pairs)] for i in range(count)]


class AddedTraffic:
    """SUMO-driven vehicles on the trips of ``pairs``, routed by SUMO; one that arrives is
    replaced by the next pair's, so that about as many as were added drive at any time.
    :meth:`after_step` keeps count of those driving and of its own time (taken out of the
    timed seconds)."""

    def __init__(self, pairs: list[tuple[str, str]]):
        self.pairs, self.next, self.driving, self.spent = pairs, 0, set(), 0.0

    def add(self, count: int) -> None:
        for _ in range(count):
            origin, destination = self.pairs[self.next % len(self.pairs)]
            name = f"{ADDED}{self.next}"
            self.next += 1
            edges = libsumo.simulation.findRoute(origin, destination).edges
            if edges:
                libsumo.route.add(name, edges)
                libsumo.vehicle.add(name, name, depart="now", departLane="best",
                                    departPos="random_free", departSpeed="max")

    def after_step(self) -> None:
        """Note the added vehicles that departed and arrived in the step; replace the
        arrived."""
        started = time.perf_counter()
        self.driving.update(v for v in libsumo.simulation.getDepartedIDList()
                            if v.startswith(ADDED))
        arrived = self.driving.intersection(libsumo.simulation.getArrivedIDList())
        self.driving -= arrived
        self.add(len(arrived))
        self.spent += time.perf_counter() - started
