"""The buckets a learner finds its neighbours in (:mod:`enn_traffic.sim.buckets`)."""

import numpy as np
import pytest

from enn_traffic.sim.buckets import buckets_for, fill, nearby


def test_the_cells_around_a_point_hold_its_neighbours_and_not_the_far_ones():
    """Cells of 10 m: from (5, 5), the 3 x 3 cells span -10..20 m on each axis."""
    centres = np.array([[5.0, 5.0], [19.0, -9.0], [21.0, 5.0], [5.0, -11.0], [14.0, 14.0],
                        [3.0, 4.0]])
    present = np.array([True, True, True, True, True, False])
    buckets = buckets_for(100_000)  # a table so wide that these cells share no bucket
    fill(buckets, centres, present, 10.0)
    out = np.empty(len(centres), dtype=np.int64)
    n = nearby(buckets, 5.0, 5.0, out)
    assert out[:n].tolist() == [0, 1, 4]  # not 2, 3 (a cell beyond), not 5 (absent)


@pytest.mark.parametrize("points, table_for", [(2000, 2000), (2000, 1)])
def test_every_point_within_a_cell_is_found_once_in_order_whatever_the_buckets_share(
        points, table_for):
    """A table of 16 buckets for 2,000 points packs many cells in each: they come along as
    extra candidates, never in place of a neighbour."""
    rng = np.random.default_rng(3)
    centres = rng.uniform(-3000.0, 3000.0, (points, 2))
    present = rng.random(points) < 0.9
    buckets = buckets_for(table_for)
    buckets = buckets._replace(order=np.empty(points, dtype=np.int64))
    fill(buckets, centres, present, 60.0)
    out = np.empty(points, dtype=np.int64)
    for x, y in centres[:300] + rng.uniform(-60.0, 60.0, (300, 2)):
        n = nearby(buckets, x, y, out)
        found = out[:n]
        within = np.flatnonzero(present & (np.hypot(*(centres - (x, y)).T) <= 60.0))
        assert np.isin(within, found).all()
        assert (np.diff(found) > 0).all() and present[found].all()
