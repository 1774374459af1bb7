"""The two-dimensional time to collision over footprints (issue 81): hand-built encounters
with hand-computed values, the ones SUMO's lane-based SSM does not pair among them."""

import math

import numpy as np
import pytest

from enn_traffic.sim.safety import least_time_among, least_time_to_contact, time_to_contact


def box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """An axis-aligned footprint, corners counter-clockwise."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


CAR = box(-4.3, -0.9, 0.0, 0.9)  # heading +x, its front bumper at x = 0


def test_rear_end():
    """A car's rear 10 m ahead, driving 5 m/s slower: 10 / 5 = 2 s."""
    ahead = box(10.0, -0.9, 14.3, 0.9)
    assert time_to_contact(CAR, ahead, -5.0, 0.0) == pytest.approx(2.0)


def test_side_swipe_in_the_next_lane():
    """Side by side at the same speed, 1 m between their sides, one drifting towards the
    other at 0.5 m/s: 1 / 0.5 = 2 s. Two lanes: SUMO's SSM never pairs them."""
    beside = box(-4.3, 1.9, 0.0, 3.7)
    assert time_to_contact(CAR, beside, 0.0, -0.5) == pytest.approx(2.0)


def test_crossing_and_a_near_miss():
    """A car crossing from the left at 5 m/s, 10 m from the car's left side, its width over
    the car's front half: 2 s. The same car 8 m further along misses: inf."""
    crossing = box(-2.0, 10.9, -0.2, 15.2)
    assert time_to_contact(CAR, crossing, 0.0, -5.0) == pytest.approx(2.0)
    assert math.isinf(time_to_contact(CAR, crossing + [8.0, 0.0], 0.0, -5.0))


def test_touching_now_and_moving_apart():
    assert time_to_contact(CAR, box(-1.0, 0.5, 3.3, 2.3), 3.0, 0.0) == 0.0
    assert math.isinf(time_to_contact(CAR, box(10.0, -0.9, 14.3, 0.9), 5.0, 0.0))


def test_a_rotated_body_is_met_by_its_corner():
    """A square turned 45° whose corner points at the car's front, 3 m ahead, closing at
    3 m/s: 1 s, where its bounding box would say 3 - (√2 - 1)·1 m sooner."""
    r = math.sqrt(2.0)
    diamond = np.array([[3.0, 0.0], [3.0 + r, -r], [3.0 + 2 * r, 0.0], [3.0 + r, r]])
    assert time_to_contact(CAR, diamond, -3.0, 0.0) == pytest.approx(1.0)


def test_the_least_over_the_slots_uses_each_vehicles_motion_since_the_step_before():
    """Three slots: one ahead closing (from its move since the step before: 2 s), one far
    beyond reach, one new in its slot (taken at rest: 10 m at the car's 10 m/s, 1 s). A
    vehicle gone from the learner's world (cleared from its start) is not met."""
    ids = np.array([[0, 1, 7], [0, 1, 2]])
    corners = np.stack([np.stack([box(20.5, -0.9, 24.8, 0.9), box(500, 0, 504, 2),
                                  box(10.0, -0.9, 14.3, 0.9)]),
                        np.stack([box(20.0, -0.9, 24.3, 0.9), box(500, 0, 504, 2),
                                  box(10.0, -0.9, 14.3, 0.9)])])
    centres = corners.mean(axis=2)
    gone = np.full(3, -1)
    ttc = least_time_to_contact(CAR, 10.0, 0.0, ids, gone, corners, centres, 0, 1, 0.1, 60.0)
    assert ttc == pytest.approx(1.0)  # the new one, at rest, 10 m ahead at 10 m/s
    gone[2] = 2  # left the learner's world: the one ahead, 20 m away, closing at 15 m/s
    ttc = least_time_to_contact(CAR, 10.0, 0.0, ids, gone, corners, centres, 0, 1, 0.1, 60.0)
    assert ttc == pytest.approx(20.0 / 15.0)
    ids[1, 2] = -1  # and an empty slot the same
    ttc = least_time_to_contact(CAR, 10.0, 0.0, ids, gone, corners, centres, 0, 1, 0.1, 60.0)
    assert ttc == pytest.approx(20.0 / 15.0)


def test_among_bodies_only_those_that_touch_within_the_horizon_count():
    """The car at 10 m/s; a stopped car 10 m ahead (1 s), one beside it at the car's own
    velocity (never), one 30 m ahead stopped (3 s, beyond a 1.5 s horizon). Horizon 1.5 s:
    1 s; the first left out: inf (the third lies beyond the horizon); horizon 5 s: 3 s."""
    bodies = np.stack([box(10.0, -0.9, 14.3, 0.9), box(-4.3, 2.0, 0.0, 3.8),
                       box(30.0, -0.9, 34.3, 0.9)])
    centres = bodies.mean(axis=1)
    velocities = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 0.0]])
    skip = np.zeros(3, dtype=np.bool_)
    gap = 2 * np.hypot(2.15, 0.9)  # two bodies' half diagonals

    def least(horizon: float) -> float:
        return least_time_among(CAR, 10.0, 0.0, bodies, centres, velocities, skip, gap, horizon)

    assert least(1.5) == pytest.approx(1.0)
    skip[0] = True
    assert math.isinf(least(1.5))
    assert least(5.0) == pytest.approx(3.0)


def test_every_collision_with_a_vehicle_in_the_committed_city_evaluation_left_a_trace(root):
    """The committed closed-loop evaluation on a multi-lane city (docs/sumo.md, "Safety
    figures"): every collision with a vehicle has a finite least 2-D time to collision, where
    SUMO's lane-based SSM saw some of them not at all."""
    import pandas as pd

    table = pd.read_csv(root / "results" / "safety" / "city_closed_loop.csv")
    hits = table[(table["outcome"] == "collision") & (table["hit"] == "vehicle")]
    assert len(hits) >= 10
    assert np.isfinite(hits["min_ttc_2d_s"]).all()
    assert np.isinf(hits["min_ttc_s"]).any()
