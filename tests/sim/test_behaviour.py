"""Behaviour kept: fixed populations give the lifetimes, outcomes, collisions, traffic met and
traces that the code gave before its step rules were written once (issue 23), in every kind of
world: the arena with each traffic strategy, SUMO replay and closed loop, many drivers learning
at once, and lane keeping."""

import numpy as np
import pytest
from behaviour_cases import GOLDEN, behaviour

from enn_traffic.sim.world import COLLIDED


@pytest.fixture(scope="module")
def today() -> dict[str, np.ndarray]:
    return behaviour()


def test_every_world_behaves_as_before(today):
    from enn_traffic.sim.lane_keeping.world import LEFT_LANE

    with np.load(GOLDEN) as golden:
        assert sorted(today) == sorted(golden.files)
        for name in golden.files:
            expected = golden[name]
            if name.startswith("lane_keeping/") and "outcome" in name:
                # a lane departure was coded as a collision before it had its own outcome
                expected = np.where(expected == COLLIDED, LEFT_LANE, expected)
            if name.startswith("sumo_") and name.endswith("/trace"):
                # SUMO's vehicles' headings in a trace come from numpy's arctan2 of their
                # bodies, whose SIMD versions differ by an ulp between CPUs (AVX-512 or not);
                # the learner's poses (column 0) are the simulation's own
                np.testing.assert_array_equal(today[name][:, 0], expected[:, 0], err_msg=name)
                np.testing.assert_allclose(today[name], expected, rtol=0, atol=1e-12,
                                           err_msg=name)
                continue
            np.testing.assert_array_equal(today[name], expected, err_msg=name)
