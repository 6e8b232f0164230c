"""Walls as exact segments in the NAO selection, checked against forward simulation.

The oracle is tests/forward_sim.py's Robot (the model written out on its own) sampled
densely, with plain numpy point-to-segment distances: an acceleration the selection
returns keeps every wall's grown radius; the first contact time and the time of
closest approach of the clearance are the simulated ones; the disk picture of a wall
lies inside its NAO; the selection is the nearest admissible acceleration (against a
brute-force grid of simulated accelerations) up to its stated tolerance; and a robot
goes through a gap that the former disc chains closed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from forward_sim import Robot
from hypothesis import example, given, settings
from hypothesis import strategies as st
from test_segment_clearance import point_segment_distance

from nao_arena.arena import Arena
from nao_arena.geometry import AccelLimits, select_acceleration
from nao_arena.geometry._kernel.bundles import Motion, Paths, Walls
from nao_arena.geometry._kernel.disks import nao_disk_samples
from nao_arena.geometry._kernel.robot_path import candidate_setup
from nao_arena.geometry._kernel.segment import wall_scan
from nao_arena.geometry.clearance import PiecewisePath, path_clearance, sampled_path
from nao_arena.geometry.walls import wall_discs
from nao_arena.maps import load_map

N_SAMPLES = 4001
HORIZON = 3.0
TIMES = np.linspace(0.0, HORIZON, 31)


def simulated_distances(v, a, v_max, walls, horizon=HORIZON, n=N_SAMPLES):
    """(times (n,), distances (W, n) m) of the robot's centre to each wall."""
    robot = Robot.make(v, a, v_max)
    t = np.linspace(0.0, horizon, n)
    x = robot.position(t)
    return t, np.array([point_segment_distance(x, w[0], w[1]) for w in walls])


def walls_only(walls, radii) -> PiecewisePath:
    """A path with no moving obstacle and the given walls (robot-relative) and radii."""
    empty = sampled_path(TIMES, np.zeros((0, len(TIMES), 2)), np.zeros(0))
    return PiecewisePath(
        empty.t,
        empty.c,
        empty.velocity,
        empty.acceleration,
        empty.radius,
        np.asarray(walls, dtype=float).reshape(-1, 2, 2),
        np.asarray(radii, dtype=float),
    )


def step_error(v, a, horizon=HORIZON, n=N_SAMPLES):
    """How far (m) the robot moves between two samples, at most: the sampling error."""
    return (float(np.hypot(*v)) + float(np.hypot(*a)) * horizon) * horizon / (n - 1)


wall_end = st.tuples(st.floats(-5.0, 5.0), st.floats(-5.0, 5.0))


@st.composite
def wall_scenes(draw):
    """Up to three walls at least their radius away from the robot, its velocity, its
    desired acceleration and speed limit."""
    walls, radii = [], []
    for _ in range(draw(st.integers(1, 3))):
        p = np.array(draw(wall_end))
        q = p + np.array(draw(st.tuples(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0))))
        r = draw(st.floats(0.2, 0.8))
        if point_segment_distance(np.zeros((1, 2)), p, q)[0] <= r + 0.05:
            continue
        walls.append([p, q])
        radii.append(r)
    v = np.array(draw(st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5))))
    desired = np.array(draw(st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))))
    v_max = draw(st.sampled_from([1.5, 2.5, math.inf]))
    return np.array(walls).reshape(-1, 2, 2), np.array(radii), v, desired, v_max


def surely_measured(v, v_max, walls, radii, a_max=2.0, horizon=HORIZON, slack=1e-6):
    """Per wall, whether the selection surely measures its clearance: the selection
    measures the walls that some acceleration could bring the robot within their radius
    of, by the documented bound (``Selection``): the robot stays within
    min(v_max T, min(|v|, v_max) T + a_max T^2 / 2) of its start. Walls within ``slack``
    (m) of that bound count as not surely measured."""
    speed = min(float(np.hypot(*v)), v_max)
    travel = min(v_max * horizon, speed * horizon + 0.5 * a_max * horizon**2)
    start = np.zeros((1, 2))
    d0 = np.array([point_segment_distance(start, w[0], w[1])[0] for w in walls])
    return d0 <= travel + radii - slack


@settings(deadline=None, max_examples=150)
@given(scene=wall_scenes())
@example(  # a far wall out of reach comes closer along the path than the near one
    scene=(
        np.array([[[0.0, 2.0], [0.0, 2.0]], [[5.0, 1.0], [5.0, 1.0]]]),
        np.array([0.5, 0.5]),
        np.zeros(2),
        np.array([1.0, 0.0]),
        1.5,
    )
)
def test_a_selected_acceleration_keeps_every_wall_clear_in_forward_simulation(scene):
    walls, radii, v, desired, v_max = scene
    sel = select_acceleration(desired, v, walls_only(walls, radii), AccelLimits(2.0), v_max=v_max)
    if not sel.feasible:
        return
    assert float(np.hypot(*sel.accel)) <= 2.0 * (1 + 1e-9)
    if len(walls) == 0:
        return
    _, d = simulated_distances(v, sel.accel, v_max, walls)
    assert np.all(d.min(axis=1) >= radii - 1e-9), (d.min(axis=1), radii)
    # the exact clearance reported for it agrees with the simulation over the walls it
    # measures, those within reach of some acceleration (inf: none was measured)
    assert sel.clearance is not None
    each = d.min(axis=1) - radii
    measured = surely_measured(v, v_max, walls, radii)
    if math.isinf(sel.clearance):
        assert float(each.min()) > 0.0 and not measured.any()
        return
    assert float(each.min()) - step_error(v, sel.accel) - 1e-9 <= sel.clearance
    if measured.any():
        assert sel.clearance <= float(each[measured].min()) + 1e-9


@settings(deadline=None, max_examples=150)
@given(
    vx=st.floats(-1.5, 1.5),
    vy=st.floats(-1.5, 1.5),
    ax=st.floats(-2.0, 2.0),
    ay=st.floats(-2.0, 2.0),
    v_max=st.sampled_from([1.0, 1.5, math.inf]),
    px=st.floats(-4.0, 4.0),
    py=st.floats(-4.0, 4.0),
    dx=st.floats(-4.0, 4.0),
    dy=st.floats(-4.0, 4.0),
    r=st.floats(0.05, 1.5),
)
def test_first_contact_and_closest_approach_match_forward_simulation(
    vx, vy, ax, ay, v_max, px, py, dx, dy, r
):
    """wall_scan's first time within r and its time of closest approach, against the
    sampled path: the first sample within r lies within a sampling step after the
    kernel's first contact (or the kernel finds none and no sample is within r - the
    step's error), and the distance at the reported closest time is the minimum."""
    v, a = np.array([vx, vy]), np.array([ax, ay])
    p, q = np.array([px, py]), np.array([px + dx, py + dy])
    t, d = simulated_distances(v, a, v_max, [[p, q]])
    d = d[0]
    cvx, cvy, tau, bound = candidate_setup(vx, vy, ax, ay, v_max, HORIZON)
    motion = Motion(cvx, cvy, ax, ay, tau, bound)
    out = np.empty(3)
    wall_scan(motion, HORIZON, px, py, px + dx, py + dy, r, True, np.empty(3), out)
    err = step_error(v, a)
    first = out[2]
    inside = np.flatnonzero(d <= r)
    if math.isinf(first):
        assert np.all(d > r - err - 1e-9)
    else:
        assert 0.0 <= first <= HORIZON
        # just after the first contact the robot is within r (+ the sampling error)
        k = min(int(np.searchsorted(t, first)), len(t) - 1)
        assert d[k] <= r + err + 1e-9
        if len(inside):
            assert t[inside[0]] >= first - 1e-9
        # before it, never within r
        assert np.all(d[t < first - 1e-9] > r - 1e-9)
    # the closest approach: the reported time's distance is the sampled minimum
    robot = Robot.make(v, a, v_max)
    at = point_segment_distance(robot.position(np.array([out[1]])), p, q)[0]
    assert abs(at - math.sqrt(out[0])) <= 1e-9 * (1.0 + at)
    assert math.sqrt(out[0]) <= d.min() + 1e-9
    assert math.sqrt(out[0]) >= d.min() - err - 1e-9


@pytest.mark.parametrize("seed", range(10))
def test_wall_disks_of_the_picture_are_inside_the_nao(seed):
    """Every disk the picture uses for a wall is made of colliding accelerations: its
    centre m at time t drives the robot (no speed limit) within the wall's radius at t,
    and so does every point of the disk (distance at t at most the radius)."""
    rng = np.random.default_rng(seed)
    walls = np.stack([rng.normal(size=(2, 2)) * 3.0, rng.normal(size=(2, 2)) * 3.0], axis=1)
    radii = rng.uniform(0.3, 0.8, size=2)
    v = rng.normal(size=2)
    empty = np.zeros((0, len(TIMES) - 1, 2))
    rows = nao_disk_samples(
        v,
        Paths(TIMES, empty, empty, empty, np.zeros(0)),
        Walls(walls, radii),
        0.0,
        2,
        np.zeros(2),
        4.0,
        2.0,
        16.0,
        0.02,
    )
    assert len(rows)
    for mx, my, rho, _ in rows:
        t = math.sqrt(2.0 * radii.max() / rho) if rho > 0 else math.inf
        # the disk's time is one of the walls' (rho = 2 r / t^2): try both radii
        ok = False
        for r in radii:
            tt = math.sqrt(2.0 * r / rho)
            for rim in (0.0, 1.0):
                ang = rng.uniform(0.0, 2.0 * math.pi)
                a = np.array([mx, my]) + rim * rho * (1 - 1e-9) * np.array(
                    [math.cos(ang), math.sin(ang)]
                )
                x = v * tt + 0.5 * a * tt * tt
                dist = min(point_segment_distance(x[None], w[0], w[1])[0] for w in walls)
                ok = ok or dist <= r * (1 + 1e-9) + 1e-9
        assert ok, (mx, my, rho, t)


@pytest.mark.parametrize("seed", range(8))
def test_the_selection_is_the_nearest_admissible_acceleration_on_a_simulated_grid(seed):
    """No acceleration of a 121 x 121 grid over the limit disc that forward simulation
    admits (clearance above the wall radius + 1 mm) lies nearer the desired one than the
    selection by more than its tolerance and sliver depth (1 % of a_max) plus the grid's
    half-diagonal (no speed limit: the exact disk picture)."""
    rng = np.random.default_rng(100 + seed)
    walls = np.stack([rng.normal(size=(3, 2)) * 2.5, rng.normal(size=(3, 2)) * 2.5], axis=1)
    radii = rng.uniform(0.3, 0.6, size=3)
    keep = [
        point_segment_distance(np.zeros((1, 2)), w[0], w[1])[0] > r + 0.1
        for w, r in zip(walls, radii, strict=True)
    ]
    walls, radii = walls[keep], radii[keep]
    v = rng.normal(size=2)
    desired = rng.normal(size=2) * 1.5
    sel = select_acceleration(desired, v, walls_only(walls, radii), AccelLimits(2.0))
    if not sel.feasible or len(walls) == 0:
        pytest.skip("nothing to compare")
    g = np.linspace(-2.0, 2.0, 121)
    grid = np.array([(x, y) for x in g for y in g if x * x + y * y <= 4.0])
    t = np.linspace(0.0, HORIZON, 301)
    x = v[None, None, :] * t[None, :, None] + 0.5 * grid[:, None, :] * t[None, :, None] ** 2
    ok = np.ones(len(grid), dtype=bool)
    for w, r in zip(walls, radii, strict=True):
        d = point_segment_distance(x.reshape(-1, 2), w[0], w[1]).reshape(len(grid), len(t))
        ok &= d.min(axis=1) > r + 1e-3
    a_d = AccelLimits(2.0).project(desired)
    best = float(np.min(np.hypot(*(grid[ok] - a_d).T)))
    got = float(np.hypot(*(sel.accel - a_d)))
    assert got <= best + 1e-3 + 0.02 + (g[1] - g[0]) / math.sqrt(2) + 1e-9, (got, best)


def test_path_clearance_reports_walls_after_the_obstacles():
    """Columns: the moving obstacles, then the walls, each against the simulation."""
    moving = sampled_path(TIMES, np.array([[[3.0, 0.0]] * len(TIMES)]), np.array([0.5]))
    wall = np.array([[[-1.0, 2.0], [1.0, 2.0]]])
    path = PiecewisePath(
        moving.t,
        moving.c,
        moving.velocity,
        moving.acceleration,
        moving.radius,
        wall,
        np.array([0.4]),
    )
    res = path_clearance(np.array([[0.0, 0.5]]), np.zeros(2), path)
    assert res.clearance.shape == (1, 2)
    _, d = simulated_distances(np.zeros(2), np.array([0.0, 0.5]), math.inf, wall)
    err = step_error(np.zeros(2), np.array([0.0, 0.5]))
    assert d.min() - 0.4 - err - 1e-9 <= res.clearance[0, 1] <= d.min() - 0.4 + 1e-9
    # straight up at 0.5 m/s^2 reaches y = 1.6 (0.4 from the wall) at t = sqrt(6.4)
    assert res.time_of_first_contact[0, 1] == pytest.approx(math.sqrt(6.4), abs=1e-9)
    assert math.isinf(res.time_of_first_contact[0, 0])


def test_walls_must_come_in_pairs_of_ends():
    empty = sampled_path(TIMES, np.zeros((0, len(TIMES), 2)), np.zeros(0))
    with pytest.raises(ValueError, match="walls: expected shape"):
        PiecewisePath(
            empty.t,
            empty.c,
            empty.velocity,
            empty.acceleration,
            empty.radius,
            np.zeros((1, 2)),
            np.zeros(1),
        )
    with pytest.raises(ValueError, match="wall_radius: expected shape"):
        PiecewisePath(
            empty.t,
            empty.c,
            empty.velocity,
            empty.acceleration,
            empty.radius,
            np.zeros((1, 2, 2)),
            np.zeros(2),
        )


GAP_MAP = """
name: narrow_gap
description: One robot through a gap 6 cm wider than its grown diameter.
bounds: {min: [-8.0, -6.0], max: [8.0, 6.0]}
walls:
  - {type: segment, a: [0.0, -6.0], b: [0.0, -%(half)s], thickness: 0.2}
  - {type: segment, a: [0.0, %(half)s], b: [0.0, 6.0], thickness: 0.2}
robots:
  - {name: through, start: [-5.0, 0.0], goal: [5.0, 0.0], radius: 0.3, a_max: 2.0,
     v_max: 1.5, agent: nao}
episode: {time_limit: 30.0, goal_tolerance: 0.1}
"""


def test_a_robot_passes_a_gap_the_disc_chains_closed(tmp_path):
    """Gap half-width = wall half-thickness + robot radius + margin (0.15) + 3 cm: open for
    exact walls. The former disc chains (radius grown by 0.1 m of slack) closed it: the
    chains' discs cover the gap's middle, so the robot could never pass."""
    half = 0.1 + 0.3 + 0.15 + 0.03
    path = tmp_path / "narrow_gap.yaml"
    path.write_text(GAP_MAP % {"half": f"{half:.3f}"})
    spec = load_map(path)
    walls, half_t = spec.wall_segments()
    centres, rad = wall_discs(walls, half_t, 0.3 + 0.15)
    assert np.any(np.hypot(*centres.T) < rad), "the disc chains leave the gap open"
    summary = Arena(spec).run(seed=0)
    robot = summary.robots[0]
    assert robot.success and robot.collisions == 0 and robot.wall_collisions == 0
    assert robot.min_separation > 0.0
