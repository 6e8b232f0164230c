"""Routes around walls (nao_arena.navigation): the grid's free cells, the distance field,
lines of sight, heading targets, and a robot that leaves a U-shaped trap only with them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.arena import Arena
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.maps import map_from_dict
from nao_arena.navigation import navigation_grid, route_targets, segment_clear

WALL = np.array([[[0.0, -3.0], [0.0, 3.0]]])  # a wall across the x axis
HALF = np.array([0.1])


def centres(grid):
    nx, ny = grid.free.shape
    xs = grid.origin[0] + (np.arange(nx) + 0.5) * grid.cell
    ys = grid.origin[1] + (np.arange(ny) + 0.5) * grid.cell
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


def test_free_cells_keep_the_clearance_from_every_wall():
    walls = np.array([[[0.0, -3.0], [0.0, 3.0]], [[2.0, 1.0], [5.0, 4.0]]])
    half = np.array([0.1, 0.0])
    grid = navigation_grid(walls, half, 0.45, np.array([[-4.0, -4.0], [6.0, 5.0]]))
    dist = point_segment_distances(centres(grid), walls) - half
    np.testing.assert_array_equal(grid.free.ravel(), np.all(dist > 0.45, axis=1))


def test_the_field_is_the_octile_distance_in_the_open_and_bends_round_a_wall():
    grid = navigation_grid(WALL, HALF, 0.45, np.array([[-6.0, -6.0], [6.0, 6.0]]))
    goal = np.array([4.0, 0.0])
    field = grid.field(goal)
    gi, gj = grid.cell_of(goal)
    assert field[gi, gj] == 0.0
    # in the open on the goal's side: the octile distance between cells
    i, j = grid.cell_of(np.array([5.0, 3.0]))
    di, dj = abs(i - gi), abs(j - gj)
    expect = grid.cell * (max(di, dj) - min(di, dj) + math.sqrt(2.0) * min(di, dj))
    assert field[i, j] == pytest.approx(expect, rel=1e-12)
    # behind the wall: longer than the straight line, which the wall blocks
    i, j = grid.cell_of(np.array([-4.0, 0.0]))
    assert field[i, j] > 8.0 + 2.0
    # never shorter than the straight line between the cell centres
    c = centres(grid).reshape(*grid.free.shape, 2)
    straight = np.hypot(*(c - c[gi, gj]).transpose(2, 0, 1))
    finite = np.isfinite(field)
    assert np.all(field[finite] >= straight[finite] - 1e-9)


def test_a_walled_in_goal_has_no_path_and_keeps_its_target():
    box = np.array(
        [
            [[-1.0, -1.0], [1.0, -1.0]],
            [[1.0, -1.0], [1.0, 1.0]],
            [[1.0, 1.0], [-1.0, 1.0]],
            [[-1.0, 1.0], [-1.0, -1.0]],
        ]
    )
    grid = navigation_grid(box, np.zeros(4), 0.3, np.array([[-5.0, -5.0], [5.0, 5.0]]))
    goal = np.array([[0.0, 0.0]])
    field = grid.field(goal[0])
    i, j = grid.cell_of(np.array([4.0, 4.0]))
    assert math.isinf(field[i, j])
    target, around = route_targets(grid, np.array([[4.0, 4.0]]), goal, np.array([0.3]))
    np.testing.assert_array_equal(target, goal)
    assert around[0]


def _sampled_clearance(a, b, walls, half):
    s = np.linspace(0.0, 1.0, 4001)
    pts = a + s[:, None] * (b - a)
    return float(np.min(point_segment_distances(pts, walls) - half))


@settings(deadline=None, max_examples=200)
@given(
    ax=st.floats(-5, 5),
    ay=st.floats(-5, 5),
    bx=st.floats(-5, 5),
    by=st.floats(-5, 5),
    sight=st.floats(0.0, 1.0),
)
def test_line_of_sight_matches_a_sampled_segment(ax, ay, bx, by, sight):
    walls = np.array([[[0.0, -3.0], [0.0, 3.0]], [[1.0, 1.0], [4.0, 2.0]]])
    half = np.array([0.1, 0.05])
    a, b = np.array([ax, ay]), np.array([bx, by])
    clear = _sampled_clearance(a, b, walls, half)
    step = float(np.hypot(*(b - a))) / 4000
    got = segment_clear(ax, ay, bx, by, walls, half, sight)
    if clear > sight + step:
        assert got
    if clear <= sight:
        assert not got


def test_a_goal_in_sight_is_the_target_and_a_hidden_one_gives_a_visible_step_closer():
    grid = navigation_grid(WALL, HALF, 0.45, np.array([[-6.0, -6.0], [6.0, 6.0]]))
    pos = np.array([[-3.0, 0.5], [2.0, 4.5]])
    goals = np.array([[4.0, 0.0], [4.0, 0.0]])
    sight = np.array([0.3, 0.3])
    out, around = route_targets(grid, pos, goals, sight)
    np.testing.assert_array_equal(out[1], goals[1])  # in sight: unchanged
    assert around.tolist() == [True, False]
    target = out[0]
    assert not np.array_equal(target, goals[0])
    assert segment_clear(pos[0, 0], pos[0, 1], target[0], target[1], WALL, HALF, 0.3)
    field = grid.field(goals[0])
    assert field[grid.cell_of(target)] < field[grid.cell_of(pos[0])]
    # it leads round an end of the wall (|y| > 3 + clearance), not into it
    assert abs(target[1]) > 3.0


TRAP = {
    "name": "u_trap",
    "description": "A robot inside a U-shaped wall open away from its goal.",
    "bounds": {"min": [-10.0, -8.0], "max": [12.0, 8.0]},
    "walls": [
        {"type": "segment", "a": [-2.0, 2.0], "b": [2.0, 2.0], "thickness": 0.2},
        {"type": "segment", "a": [2.0, 2.0], "b": [2.0, -2.0], "thickness": 0.2},
        {"type": "segment", "a": [2.0, -2.0], "b": [-2.0, -2.0], "thickness": 0.2},
    ],
    "robots": [
        {
            "name": "r",
            "start": [0.0, 0.0],
            "goal": [8.0, 0.0],
            "radius": 0.3,
            "a_max": 2.0,
            "v_max": 1.5,
            "agent": "nao",
            "agent_options": {"navigate": True},
        }
    ],
    "episode": {"time_limit": 60.0, "goal_tolerance": 0.1},
}


@pytest.mark.parametrize("navigate", [True, False])
def test_a_robot_leaves_a_u_shaped_trap_only_by_navigating(navigate):
    spec = dict(TRAP)
    spec["robots"] = [dict(TRAP["robots"][0], agent_options={"navigate": navigate})]
    summary = Arena(map_from_dict(spec)).run(seed=0)
    robot = summary.robots[0]
    assert robot.collisions == 0 and robot.wall_collisions == 0
    assert robot.success is navigate, robot
