"""A learner inside SUMO (closed loop): added as a vehicle with no route that obeys no speed
or lane-change rule, moved each step with ``moveToXY`` (keepRoute=2), so that SUMO's traffic
reacts to it; and taken out again."""

from __future__ import annotations

import libsumo

from enn_traffic.sumo.command import LEARNER, LEARNER_TYPE, to_angle
from enn_traffic.sumo.simulation import MATCH_M, Simulation


def learner_id(index: int) -> str:
    """The SUMO id of learner ``index`` (the first, or only, is :data:`LEARNER`)."""
    return LEARNER if index == 0 else f"{LEARNER}_{index}"


def add_learner(length: float, width: float, speed: float, vehicle: str = LEARNER,
                ssm_device: bool = False) -> None:
    """Put a learner into the running SUMO as a vehicle with no route, that obeys no speed
    or lane-change rule and is moved by :func:`move_learner` (the learners share one
    vehicle type, made with the first). It carries an SSM device if ``ssm_device`` (the
    first learner's choice holds for all), which measures and writes as the start's options
    say: only for a start given :func:`~enn_traffic.sumo.ssm.ssm_options`
    (``Simulation.has_ssm_options``; without them SUMO writes the device's file into the
    working folder)."""
    kind = LEARNER_TYPE
    if kind not in libsumo.vehicletype.getIDList():
        libsumo.vehicletype.copy("DEFAULT_VEHTYPE", kind)
        # SUMO equips a vehicle by its type's parameter at every start (its own list of
        # vehicle ids, --device.ssm.explicit, is read once per process: ssm.ssm_options)
        libsumo.vehicletype.setParameter(kind, "has.ssm.device", str(ssm_device).lower())
        libsumo.vehicletype.setLength(kind, length)
        libsumo.vehicletype.setWidth(kind, width)
        libsumo.vehicletype.setMaxSpeed(kind, max(speed, 1e-3))
        libsumo.vehicletype.setSpeedDeviation(kind, 0.0)
        libsumo.vehicletype.setImperfection(kind, 0.0)
        # The least speed factor that lets it go its own speed on every lane it may drive
        # (moveToXY places it at that speed whatever the lane's limit; SSM sees it at that
        # speed from its insertion on). A far larger factor makes SUMO plan its stopping
        # distance across the city every step (a factor of 100 cost 876 ms a step on a
        # 9,700-lane city, docs/sumo.md "Learners at SUMO's pace").
        libsumo.vehicletype.setSpeedFactor(kind, learner_speed_factor(speed))
    try:
        libsumo.vehicle.add(vehicle, "", typeID=kind, departSpeed=f"{speed:g}")
        libsumo.vehicle.setSpeedMode(vehicle, 0)
        libsumo.vehicle.setLaneChangeMode(vehicle, 0)
        libsumo.vehicle.setSpeed(vehicle, speed)  # for its first step; then SUMO derives it
    except libsumo.TraCIException as exc:
        if Simulation.running is None:
            raise
        Simulation.running._fail(f"SUMO refused the learner {vehicle!r}", exc)


def learner_speed_factor(speed: float) -> float:
    """``speed`` over the lowest speed limit of the running SUMO's lanes that allow passenger
    cars, junctions' internal lanes too (at least 1): the learners' type then has room to go
    ``speed`` on each."""
    limits = [libsumo.lane.getMaxSpeed(lane) for lane in libsumo.lane.getIDList()
              if _allows_cars(lane)]
    return max(1.0, speed / min(limits)) if limits else 1.0


def _allows_cars(lane: str) -> bool:
    allowed, disallowed = libsumo.lane.getAllowed(lane), libsumo.lane.getDisallowed(lane)
    return ("passenger" in allowed or not allowed) and "passenger" not in disallowed


def remove_learner(vehicle: str = LEARNER) -> None:
    """Take a learner out of the running SUMO, its subscription first (libsumo would go on
    asking for the variables of a vehicle it no longer knows and stop)."""
    libsumo.vehicle.unsubscribe(vehicle)
    libsumo.vehicle.remove(vehicle)


def move_learner(x: float, y: float, heading: float, vehicle: str = LEARNER) -> None:
    """Place the learner for SUMO's next step (keepRoute=2: anywhere, on a lane or not); SUMO
    takes its speed from the distance moved. Lanes are looked for within MATCH_M first (the
    learner is on the drivable area, so one is that near; a wider search costs twice as
    much), then anywhere."""
    try:
        libsumo.vehicle.moveToXY(vehicle, "", -1, x, y, to_angle(heading), keepRoute=2,
                                 matchThreshold=MATCH_M)
    except libsumo.TraCIException:
        libsumo.vehicle.moveToXY(vehicle, "", -1, x, y, to_angle(heading), keepRoute=2,
                                 matchThreshold=1e6)
