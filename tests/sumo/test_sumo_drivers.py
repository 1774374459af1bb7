"""``[traffic.drivers]`` through a real libsumo: SUMO's driver models and demand set on every
traffic vehicle (docs/sumo.md, "Driver models"), never on the learners, and kept apart in the
warm-ups saved on disk."""

from contextlib import contextmanager

import libsumo
import pytest

from enn_traffic.config import load_scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.sumo import command, states
from enn_traffic.sumo.learners import add_learner
from enn_traffic.sumo.simulation import Simulation

# The ring road of sumo_strategy1: 32 cars of one type ("car": Krauss, sigma 0.5, tau 1).
DRIVERS = {"imperfection": 0.9, "tau_s": 0.6, "accel": 1.5, "decel": 3.0, "speed_factor": 1.2,
           "lc_speed_gain": 8.0, "lc_cooperative": 0.2}


def ring(**drivers):
    return shipped_scenario("sumo_strategy1").with_overrides(
        traffic={"drivers": drivers, "warmup_s": 2.0})


@contextmanager
def traffic_after(scenario, steps: int = 20, learner: bool = False):
    """Start the scenario's SUMO (with a learner when asked), step it, give its vehicles;
    SUMO closes on leaving."""
    simulation = Simulation(scenario, seed=1)
    try:
        if learner:
            add_learner(4.5, 1.7, 10.0)
        simulation.step(steps)
        yield [v for v in libsumo.vehicle.getIDList() if v != command.LEARNER]
    finally:
        simulation.close()


def test_driver_values_reach_every_traffic_vehicle_but_not_the_learner():
    with traffic_after(ring(**DRIVERS), learner=True) as vehicles:
        assert len(vehicles) == 32
        for vehicle in vehicles:
            assert libsumo.vehicle.getImperfection(vehicle) == pytest.approx(0.9)
            assert libsumo.vehicle.getTau(vehicle) == pytest.approx(0.6)
            assert libsumo.vehicle.getAccel(vehicle) == pytest.approx(1.5)
            assert libsumo.vehicle.getDecel(vehicle) == pytest.approx(3.0)
            assert float(libsumo.vehicle.getParameter(
                vehicle, "laneChangeModel.lcSpeedGain")) == 8.0
            assert float(libsumo.vehicle.getParameter(
                vehicle, "laneChangeModel.lcCooperative")) == pytest.approx(0.2)
        assert libsumo.vehicletype.getSpeedFactor("car") == pytest.approx(1.2)
        # The learner keeps its own type: a perfect driver, SUMO's default lane-change values.
        assert libsumo.vehicle.getImperfection(command.LEARNER) == 0.0
        assert float(libsumo.vehicle.getParameter(
            command.LEARNER, "laneChangeModel.lcSpeedGain")) == 1.0


def test_without_drivers_the_route_files_values_stand():
    with traffic_after(ring()) as vehicles:
        for vehicle in vehicles:
            assert libsumo.vehicle.getImperfection(vehicle) == pytest.approx(0.5)
            assert libsumo.vehicle.getTau(vehicle) == pytest.approx(1.0)


def test_demand_scale_and_car_following_model():
    """``demand_scale = 2``: SUMO inserts each of the 32 cars twice. ``car_following = "IDM"``:
    the cars follow the Intelligent Driver Model, which has no Krauss imperfection (SUMO
    reports -1)."""
    with traffic_after(ring(demand_scale=2.0, car_following="IDM")) as vehicles:
        assert len(vehicles) == 64
        assert all(libsumo.vehicle.getImperfection(v) == -1.0 for v in vehicles)


def test_a_warm_up_is_kept_per_driver_model_and_loads_with_it():
    """Warm-ups saved on disk are named by the drivers too (a stale warm-up of other drivers
    is never loaded), and a run from a saved warm-up drives with the scenario's drivers."""
    calm, dawdling = ring(), ring(imperfection=0.9)
    state = states.warm_state(dawdling, seed=1, keep_rng=False)
    assert state != states.warm_state(calm, seed=1, keep_rng=False)
    simulation = Simulation(dawdling, seed=2, state=state)
    try:
        vehicles = libsumo.vehicle.getIDList()
        assert len(vehicles) == 32
        assert all(libsumo.vehicle.getImperfection(v) == pytest.approx(0.9) for v in vehicles)
    finally:
        simulation.close()


RING = """name = "ring"
[track]
net = "{root}/sumo_nets/sumo_ring.net.xml"
start_lane = "g0_0to1_0_1"
[traffic]
strategy = "{strategy}"
{routes}
[traffic.drivers]
{drivers}
"""


@pytest.mark.parametrize("strategy, drivers, key, message", [
    ("sumo", "imperfection = 1.5", "traffic.drivers.imperfection", "less than or equal to 1"),
    ("sumo", 'car_following = "Kraus"', "traffic.drivers.car_following", "'Krauss'"),
    ("sumo", "lc_speed_gain = -1", "traffic.drivers.lc_speed_gain", "greater than or equal"),
    ("wander", "tau_s = 0.5", "traffic", 'is for strategy = "sumo"'),
])
def test_bad_driver_values_name_file_and_key(tmp_path, root, strategy, drivers, key, message):
    routes = (f'routes = ["{root}/scenarios/routes/ring_steady.rou.xml"]' if strategy == "sumo"
              else "")
    path = tmp_path / "s.toml"
    path.write_text(RING.format(root=root, strategy=strategy, routes=routes, drivers=drivers))
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert info.value.key == key
    assert message in info.value.message


def test_a_scaled_city_state_loads(tmp_path):
    """Cologne's demand scaled by 1.5: SUMO's copies of a vehicle share its embedded route,
    which SUMO may leave out of a saved state; :meth:`sumo.Simulation.save_state` writes those
    routes into it, so the state loads and the copies drive on. (Saved here, not through the
    warm-ups kept on disk, so that the saving is tested whatever those hold.)"""
    scenario = shipped_scenario("city_cologne3").with_overrides(
        traffic={"drivers": {"demand_scale": 1.5}})
    state = tmp_path / "state.xml.gz"
    simulation = Simulation(scenario, seed=3)
    try:
        simulation.step(6000)  # 600 s: seed 3 then leaves a copy's route out (checked)
        simulation.save_state(state)
    finally:
        simulation.close()
    simulation = Simulation(scenario, seed=3, state=state)
    try:
        assert any(v.endswith(".1") for v in libsumo.vehicle.getIDList())
        simulation.step(60)
        assert libsumo.vehicle.getIDCount() > 0
    finally:
        simulation.close()
