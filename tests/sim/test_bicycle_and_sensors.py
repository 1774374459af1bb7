import math

import numpy as np
import pytest

from enn_traffic.core.geometry import body_polygon, box_hits_segment, boxes_overlap
from enn_traffic.sim.bicycle import bicycle_step
from enn_traffic.sim.readings import beam_table
from enn_traffic.sim.sensors import (
    ANGLE_MARGIN,
    WallGrid,
    nearby_walls,
    ray_segment_distance,
    rough_atan2,
    sense_bodies,
    sense_walls,
)


@pytest.mark.parametrize(
    "steering_deg, turn_deg, moved",
    # docs/design.md, "The authors' code" 2, d = 1 m, wheelbase 2.6 m
    [(10, 3.8, 0.996), (30, 11.5, 0.966), (45, 17.0, 0.924), (60, 22.4, 0.866)],
)
def test_bicycle_step_matches_the_authors_table(steering_deg, turn_deg, moved):
    x, y, heading = bicycle_step(3.0, -2.0, 0.3, math.radians(steering_deg), 1.0, 2.6)
    assert math.degrees(heading - 0.3) == pytest.approx(turn_deg, abs=0.05)
    assert math.hypot(x - 3.0, y + 2.0) == pytest.approx(moved, abs=0.0005)


def test_bicycle_step_closed_form():
    delta, d, wb, heading = 0.7, 1.0, 2.6, 1.1
    x, y, new_heading = bicycle_step(0.0, 0.0, heading, delta, d, wb)
    assert new_heading - heading == pytest.approx(
        math.atan2(d * math.sin(delta), wb + d * (math.cos(delta) - 1)))
    body = np.array([d / 2 * (1 + math.cos(delta)), d / 2 * math.sin(delta)])
    c, s = math.cos(heading), math.sin(heading)
    assert (x, y) == pytest.approx((c * body[0] - s * body[1], s * body[0] + c * body[1]))


def test_straight_step_moves_the_full_distance():
    moved = bicycle_step(1.0, 2.0, math.pi / 2, 0.0, 1.0, 2.6)
    assert moved == pytest.approx((1.0, 3.0, math.pi / 2))


def test_body_extends_behind_the_front_bumper():
    corners = body_polygon(10.0, 5.0, math.pi / 2, 4.3, 1.7)  # heading north
    np.testing.assert_allclose(
        corners, [[10.85, 5.0], [9.15, 5.0], [9.15, 0.7], [10.85, 0.7]], atol=1e-12)


def test_box_segment_tests():
    box = body_polygon(0.0, 0.0, 0.0, 4.3, 1.7)  # spans x -4.3..0, y -0.85..0.85
    assert box_hits_segment(box, 0.5, -2.0, -0.5, 2.0)  # crosses the front edge
    assert box_hits_segment(box, -2.0, 0.0, -1.0, 0.1)  # lies wholly inside the body
    assert not box_hits_segment(box, 0.2, -2.0, 0.2, 2.0)  # 0.2 m ahead of the bumper
    assert boxes_overlap(box, body_polygon(1.0, 0.5, 0.3, 4.3, 1.7))
    assert not boxes_overlap(box, body_polygon(0.0, 3.0, 0.0, 4.3, 1.7))


SQUARE = np.array([[0, 0, 100, 0], [100, 0, 100, 100], [100, 100, 0, 100], [0, 100, 0, 0]],
                  dtype=float)


def _readings(x, y, heading, angles, max_range=25.0, walls=SQUARE, candidates=None):
    """Readings of beams at ``angles`` (all ``max_range`` long, or each its own) against
    ``candidates`` (every wall)."""
    out = np.empty(len(angles))
    ranges = np.broadcast_to(max_range, (len(angles),))
    candidates = np.arange(len(walls)) if candidates is None else candidates
    sense_walls(x, y, math.cos(heading), math.sin(heading),
                beam_table(list(zip(angles, ranges, strict=True))), walls, candidates, out)
    return out


def test_rangefinder_hand_computed_in_a_square():
    # at (90, 40) heading east: right beam sees y=0 at 40 (beyond range), ahead x=100 at 10,
    # left sees y=100 at 60 (beyond range); 45 degrees right or left hits x=100 at 10*sqrt(2)
    got = _readings(90.0, 40.0, 0.0, np.linspace(-math.pi / 2, math.pi / 2, 5))
    np.testing.assert_allclose(got, [25.0, 10 * math.sqrt(2), 10.0, 10 * math.sqrt(2), 25.0])
    got = _readings(90.0, 40.0, 0.0, [-math.pi / 2, 0.0, math.pi / 2], max_range=100.0)
    np.testing.assert_allclose(got, [40.0, 10.0, 60.0])


def test_grid_culling_gives_the_same_readings_as_all_walls(root):
    from enn_traffic.roads import load_track

    track = load_track(root / "sumo_nets" / "track_narrow.net.xml")
    grid = WallGrid.build(track.walls, reach=26.0)
    rng = np.random.default_rng(0)
    angles = np.linspace(-math.pi / 2, math.pi / 2, 19)
    for _ in range(300):
        x, y = rng.uniform(-240, 40), rng.uniform(-35, 225)
        heading = rng.uniform(-math.pi, math.pi)
        near = nearby_walls(x, y, grid, grid.cell_start, grid.cell_walls, grid.all_walls)
        culled = _readings(x, y, heading, angles, 25.0, track.walls, near)
        np.testing.assert_array_equal(culled, _readings(x, y, heading, angles, 25.0, track.walls))
        assert len(near) < len(track.walls) or not track.contains(x, y)


def test_rough_bearing_stays_well_inside_the_beam_windows_margin():
    """The beam windows' bearings are rough (a polynomial, not libm's atan2); their error,
    over every direction and scale, stays a fifth of the margin the windows are widened by."""
    rng = np.random.default_rng(0)
    angles = np.concatenate([np.linspace(-math.pi, math.pi, 20_001), rng.uniform(-4, 4, 20_000)])
    scales = 10.0 ** rng.uniform(-6, 4, len(angles))
    worst = max(abs(rough_atan2(r * math.sin(a), r * math.cos(a)) - math.atan2(math.sin(a),
                                                                               math.cos(a)))
                for a, r in zip(angles, scales, strict=True))
    assert 1e-6 < worst < ANGLE_MARGIN / 5
    assert rough_atan2(0.0, 0.0) == 0.0 and rough_atan2(1.0, 0.0) == pytest.approx(math.pi / 2)


def _every_beam_every_segment(x, y, heading, angles, max_range, segments):
    """The rangefinder's rule without any culling: every beam against every segment
    (``max_range``: every beam's, or each its own)."""
    readings = np.array(np.broadcast_to(max_range, (len(angles),)), dtype=float)
    for b, angle in enumerate(angles):
        ux, uy = math.cos(heading) * math.cos(angle) - math.sin(heading) * math.sin(angle), \
            math.sin(heading) * math.cos(angle) + math.cos(heading) * math.sin(angle)
        for x1, y1, x2, y2 in segments:
            readings[b] = min(readings[b], ray_segment_distance(x, y, ux, uy, readings[b],
                                                                x1, y1, x2, y2))
    return readings


@pytest.mark.parametrize("beams, span_deg", [(19, 180), (1, 180), (7, 360), (12, 300)])
def test_beam_windows_find_what_every_beam_against_every_wall_finds(beams, span_deg):
    """Each wall is tested only along the beams within its angular extent: short and long
    walls all around the vehicle, behind it and through the bearing ±π, give bit for bit
    the readings of every beam tested against every wall."""
    rng = np.random.default_rng(beams)
    span = math.radians(span_deg)
    angles = np.array([-span / 2 + span * i / max(beams - 1, 1) for i in range(beams)])
    for _ in range(400):
        x, y, heading = rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi)
        middle = rng.uniform(-30, 30, (6, 2))
        half = rng.uniform(-15, 15, (6, 2)) * rng.choice([0.05, 1.0], (6, 1))
        walls = np.hstack([middle - half, middle + half])
        np.testing.assert_array_equal(
            _readings(x, y, heading, angles, 25.0, walls),
            _every_beam_every_segment(x, y, heading, angles, 25.0, walls))


def test_a_second_ring_behind_reads_what_every_beam_against_every_wall_reads():
    """Two rings (``[[sensor.rings]]``): the paper's 19 beams over 180° ahead, 25 m, and 5
    beams over 90° behind, 8 m (angles past ±π). Walls and bodies all around give bit for bit
    what each beam, with its own range, reads against every edge."""
    from enn_traffic.config import fan

    angles = np.array(fan(19, math.pi) + fan(5, math.pi / 2, math.pi))
    ranges = np.array([25.0] * 19 + [8.0] * 5)
    table = beam_table(list(zip(angles, ranges, strict=True)))
    rng = np.random.default_rng(7)
    radius = 0.5 * math.hypot(4.3, 1.8)
    behind = 0
    for _ in range(300):
        heading = rng.uniform(-math.pi, math.pi)
        middle = rng.uniform(-20, 20, (6, 2))
        half = rng.uniform(-10, 10, (6, 2)) * rng.choice([0.05, 1.0], (6, 1))
        walls = np.hstack([middle - half, middle + half])
        poses = np.column_stack([rng.uniform(-12, 12, (4, 2)), rng.uniform(-math.pi, math.pi, 4)])
        corners = np.stack([body_polygon(*pose, 4.3, 1.8) for pose in poses])
        readings = np.empty(24)
        sense_walls(0.0, 0.0, math.cos(heading), math.sin(heading), table, walls,
                    np.arange(len(walls)), readings)
        sense_bodies(-1, 0.0, 0.0, math.cos(heading), math.sin(heading), table, corners,
                     corners.mean(axis=1), corners.mean(axis=1), radius, 0.1, readings,
                     None)
        edges = np.concatenate([walls] + [np.hstack([body, np.roll(body, -1, axis=0)])
                                          for body in corners])
        np.testing.assert_array_equal(
            readings, _every_beam_every_segment(0.0, 0.0, heading, angles, ranges, edges))
        behind += int((readings[19:] < 8.0).sum())
    assert behind > 100  # the rear ring saw things, within its own 8 m


def test_bodies_seen_through_facing_edges_as_through_all_four():
    """Another body is tested only along the edges that face the sensing vehicle, and along
    the beams near its bearing: bodies all around, touching and overlapping the vehicle's
    point, read bit for bit what every beam against every edge reads."""
    rng = np.random.default_rng(3)
    angles = np.array([-math.pi / 2 + math.pi * i / 18 for i in range(19)])
    radius = 0.5 * math.hypot(4.3, 1.8)
    inside = 0
    for _ in range(300):
        heading = rng.uniform(-math.pi, math.pi)
        poses = np.column_stack([rng.uniform(-12, 12, (6, 2)), rng.uniform(-math.pi, math.pi, 6)])
        corners = np.stack([body_polygon(*pose, 4.3, 1.8) for pose in poses])
        centres = corners.mean(axis=1)
        readings = np.full(19, 25.0)
        sense_bodies(-1, 0.0, 0.0, math.cos(heading), math.sin(heading),
                     beam_table([(a, 25.0) for a in angles]), corners, centres, centres, radius,
                     0.1, readings, None)
        edges = np.concatenate([np.hstack([body, np.roll(body, -1, axis=0)]) for body in corners])
        np.testing.assert_array_equal(
            readings, _every_beam_every_segment(0.0, 0.0, heading, angles, 25.0, edges))
        inside += any(box_hits_segment(body, -1e-3, 0.0, 1e-3, 0.0) for body in corners)
    assert inside > 5  # the point inside a body, where every edge faces it, was met


def test_grid_lists_exactly_the_walls_near_each_cell(root, monkeypatch):
    """Each cell lists, in ascending order, exactly the walls within reach plus half the
    cell's diagonal of its centre: the answer of the distance from every cell to every wall
    (:func:`reference_wall_grid`). Tiny chunks make walls' candidate cells straddle chunk
    boundaries."""
    from enn_traffic.roads import load_track
    from enn_traffic.sim import sensors
    from enn_traffic.sim.reference import reference_wall_grid

    walls = load_track(root / "sumo_nets" / "track_grid.net.xml").walls
    monkeypatch.setattr(sensors, "PAIRS_PER_CHUNK", 97)
    grid = WallGrid.build(walls, 26.0, 5.0)
    cell_start, cell_walls = reference_wall_grid(walls, 26.0, 5.0)
    assert len(cell_walls) > 10 * len(walls)  # cells list many walls
    np.testing.assert_array_equal(grid.cell_start, cell_start)
    np.testing.assert_array_equal(grid.cell_walls, cell_walls)
