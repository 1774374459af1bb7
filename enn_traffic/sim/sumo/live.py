"""A live SUMO with one learner in it, stepped from Python: the closed loop's traffic
(:meth:`~enn_traffic.sim.sumo.world.SumoWorld.closed_loop`, and the closed-loop SUMO
gymnasium environment, :mod:`enn_traffic.envs.sumo`)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.sim.rules import Geometry, Physics
from enn_traffic.sim.sumo.replay import clear_start, learner_state, with_slots
from enn_traffic.sumo import command, recording, ssm
from enn_traffic.sumo.learners import add_learner, move_learner
from enn_traffic.sumo.simulation import Simulation


class LearnersWorld(Protocol):
    """What the live traffic takes of its world (a
    :class:`~enn_traffic.sim.sumo.world.SumoWorld`)."""

    scenario: Scenario
    geometry: Geometry
    layer_sizes: np.ndarray

    def _learner_physics(self, radius: float) -> Physics: ...


class LiveTraffic:
    """A live SUMO with one learner in it (the closed loop), stepped from Python: the slot
    arrays' rows ``before`` and ``now`` (they swap roles every step, instead of copying) hold
    SUMO's vehicles at the step before and now; ``state`` is the learner's
    (:class:`~enn_traffic.sim.sumo.replay.LearnerState`) and ``t`` the steps it has moved. Each
    step: the learner senses, decides and moves (:func:`~enn_traffic.sim.sumo.replay.learner_step`,
    or its halves), then :meth:`advance`. :meth:`close` ends SUMO."""

    def __init__(self, world: LearnersWorld, simulation: Simulation, start: np.ndarray):
        vehicle = world.scenario.vehicle
        self.simulation = simulation
        self.reach = None  # known once the learner is in SUMO
        self.t = 0
        try:
            self.physics = world._learner_physics(simulation.largest_radius())
            self.ids, self.corners, self.centres = recording.slot_arrays(2, 64)
            self.before, self.now = 0, 1
            self.state = learner_state(start, self.physics, world.geometry,
                                       world.layer_sizes, self.ids.shape[1])
            self._read()
            self.at_start = int((self.ids[self.now] >= 0).sum())
            clear_start(self.state.learner.centres, self.ids[self.now], self.centres[self.now],
                        self.state.gone, self.physics.clearance)
            add_learner(vehicle.length, vehicle.width, vehicle.speed,
                        ssm_device=simulation.has_ssm_options)
            # Vehicles farther than this from the learner's front bumper can neither be seen
            # nor be hit within a step: the sensor's range, two bodies and two steps of both
            # vehicles' travel.
            travel = (simulation.largest_speed() + vehicle.speed) * vehicle.dt
            self.reach = world.scenario.max_range + 2.0 * travel
            simulation.follow_learner(self.followed)
        except BaseException:
            simulation.close()
            raise

    def _read(self) -> None:
        """SUMO's vehicles into row ``now`` of the slot arrays (:func:`sumo.read_frame`), the
        learner state's per-slot arrays growing with them; a body larger than its type said
        widens the radius beyond which bodies cannot touch."""
        (self.ids, self.corners, self.centres), radius = recording.read_frame(
            self.simulation, self.now, (self.ids, self.corners, self.centres))
        if self.ids.shape[1] > len(self.state.gone):
            self.state = with_slots(self.state, self.ids.shape[1])
        if radius > self.physics.radius:
            self.physics = self.physics._replace(radius=radius)
            if self.reach is not None:
                self.simulation.follow_learner(self.followed)

    @property
    def followed(self) -> float:
        """How far from the learner SUMO's vehicles are read each step (m)."""
        return self.reach + 4.0 * self.physics.radius

    def advance(self) -> None:
        """The learner where it moved, SUMO one step on, its vehicles read."""
        move_learner(*self.state.learner.pose[0])
        self.simulation.step()
        self.before, self.now = self.now, self.before
        self._read()
        self.t += 1

    def vehicle(self, hit: int) -> tuple[str, str] | None:
        """The SUMO id and type of vehicle number ``hit`` (None for a wall or nothing)."""
        return (self.simulation.names[hit], self.simulation.types[hit]) if hit >= 0 else None

    def close(self) -> ssm.Conflicts:
        """End SUMO (it writes the SSM file as it closes) and read the conflicts."""
        output = self.simulation.close(read=(command.SSM_FILE,))[command.SSM_FILE]
        return ssm.read_conflicts(output)
