"""Lanes, lane followers and the true future paths of scripted traffic."""

from __future__ import annotations

import numpy as np
import pytest

from nao_arena.maps import load_map, map_from_dict
from nao_arena.stats import EpisodeStats
from nao_arena.traffic import (
    CircleLane,
    FollowerParams,
    LaneTraffic,
    PolylineLane,
    follower_accel,
    future_path,
    leader_gaps,
)
from nao_arena.world import World

# Stated accuracy of the known future path of undisturbed traffic over 3 s (m).
PATH_TOL = 0.05


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_circle_lane_parametrization(direction: str) -> None:
    lane = CircleLane((1.0, -2.0), 5.0, direction, start_angle=0.3)
    s = np.linspace(0.0, lane.length, 50, endpoint=False)
    p = lane.point_at(s)
    np.testing.assert_allclose(np.hypot(*(p - [1.0, -2.0]).T), 5.0)
    # unit speed along s, tangent = derivative of the point
    ds = 1e-6
    np.testing.assert_allclose((lane.point_at(s + ds) - p) / ds, lane.tangent_at(s), atol=1e-5)
    s_back, lateral = lane.project(p)
    np.testing.assert_allclose(s_back, s, atol=1e-9)
    np.testing.assert_allclose(lateral, 0.0, atol=1e-9)
    sign = 1.0 if direction == "ccw" else -1.0
    assert np.all(lane.curvature_at(s) == sign / 5.0)
    # a point 0.5 m to the left of the driving direction has lateral offset +0.5
    t = lane.tangent_at(s)
    left = p + 0.5 * np.stack([-t[:, 1], t[:, 0]], axis=1)
    np.testing.assert_allclose(lane.project(left)[1], 0.5, atol=1e-9)


@pytest.mark.parametrize("closed", [False, True])
def test_polyline_lane_parametrization(closed: bool) -> None:
    lane = PolylineLane(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 5.0], [0.0, 5.0]]), closed)
    assert lane.length == (30.0 if closed else 25.0)
    s = np.array([0.0, 4.0, 10.0, 12.5, 20.0, 24.0])
    np.testing.assert_allclose(
        lane.point_at(s), [[0, 0], [4, 0], [10, 0], [10, 2.5], [5, 5], [1, 5]], atol=1e-12
    )
    s_back, lateral = lane.project(lane.point_at(s) + [0.0, 0.3])
    np.testing.assert_allclose(s_back[[1, 4]], [4.0, 20.0])
    np.testing.assert_allclose(lateral[[1, 4]], [0.3, -0.3])
    np.testing.assert_allclose(lane.tangent_at(np.array([5.0, 11.0])), [[1, 0], [0, 1]])
    if closed:
        np.testing.assert_allclose(lane.point_at(27.0), [0.0, 3.0])  # the closing segment
        np.testing.assert_allclose(lane.point_at(32.0), [2.0, 0.0])  # wraps around
    else:
        # beyond the end the lane continues straight
        np.testing.assert_allclose(lane.point_at(27.0), [-2.0, 5.0])
        np.testing.assert_allclose(lane.project(np.array([[-2.0, 5.0]]))[0], [27.0])
        np.testing.assert_allclose(lane.point_at(-1.0), [-1.0, 0.0])


def test_leader_gaps_closed_and_open() -> None:
    ring = CircleLane((0.0, 0.0), 10.0)
    s = np.array([5.0, 50.0, 20.0])
    leader, gap = leader_gaps(ring, s, np.ones(3))
    assert list(leader) == [2, 0, 1]
    np.testing.assert_allclose(gap, [13.0, ring.length - 45.0 - 2.0, 28.0])
    road = PolylineLane(np.array([[0.0, 0.0], [100.0, 0.0]]))
    leader, gap = leader_gaps(road, s, np.ones(3))
    assert list(leader) == [2, -1, 1]
    assert gap[1] == np.inf
    assert leader_gaps(ring, np.array([3.0]), np.ones(1))[0][0] == -1


def test_free_follower_reaches_and_holds_cruise_speed() -> None:
    lane = PolylineLane(np.array([[0.0, 0.0], [1000.0, 0.0]]))
    prm = FollowerParams(speed=6.0, a_max=2.0)
    p, v = np.array([0.0, 0.4]), np.zeros(2)
    for _ in range(300):
        a = follower_accel(lane, prm, 0.1, p, v, radius=1.0)
        assert np.hypot(*a) <= 2.0 * (1 + 1e-12)
        p, v = p + v * 0.1 + 0.5 * a * 0.01, v + a * 0.1
    assert v[0] == pytest.approx(6.0, abs=1e-6)
    assert abs(p[1]) < 1e-3 and abs(v[1]) < 1e-3


def test_follower_brakes_behind_a_slow_leader() -> None:
    lane = PolylineLane(np.array([[0.0, 0.0], [1000.0, 0.0]]))
    prm = FollowerParams(speed=8.0, a_max=3.0)
    far = follower_accel(lane, prm, 0.1, [0, 0], [8, 0], 1.0, [200, 0], [2, 0], 1.0)
    near = follower_accel(lane, prm, 0.1, [0, 0], [8, 0], 1.0, [15, 0], [2, 0], 1.0)
    assert far[0] == pytest.approx(0.0, abs=1e-9)
    assert near[0] < -1.0


@pytest.mark.slow
def test_fast_lane_never_rear_ends_a_slow_one_in_the_world() -> None:
    """Two groups on one straight lane: fast cars catch up with a slow car and queue."""
    spec = map_from_dict(
        {
            "bounds": {"min": [-10, -10], "max": [600, 10]},
            "robots": [{"start": [0, 8], "goal": [1, 8]}],
            "traffic": [
                {
                    "lane": {"type": "polyline", "points": [[0, 0], [600, 0]]},
                    "speed": 2.0,
                    "count": 1,
                    "offset": 60.0,
                    "a_max": 3.0,
                },
                {
                    "lane": {"type": "polyline", "points": [[0, 0], [600, 0]]},
                    "speed": 10.0,
                    "count": 3,
                    "spacing": 12.0,
                    "offset": 0.0,
                    "a_max": 3.0,
                },
            ],
        }
    )
    world = World(spec)
    lane = spec.traffic[0].lane_geometry()
    idx = np.arange(1, 5)
    radii = world.radii[idx]
    stats = EpisodeStats(world.radii, world.kinds, world.names, dt=world.dt)
    state = world.state()
    min_gap = np.inf
    for _ in range(300):
        # one queue: every car follows its leader on the shared lane
        s, _ = lane.project(state.positions[idx])
        leader, gap = leader_gaps(lane, s, radii)
        a = np.zeros((world.n, 2))
        for k, car in enumerate(idx):
            prm = FollowerParams(speed=2.0 if k == 0 else 10.0, a_max=3.0)
            lead = None if leader[k] < 0 else idx[leader[k]]
            a[car] = follower_accel(
                lane,
                prm,
                world.dt,
                state.positions[car],
                state.velocities[car],
                1.0,
                None if lead is None else state.positions[lead],
                None if lead is None else state.velocities[lead],
                1.0,
            )
        new = world.step(a)
        stats.update(
            state.time, state.positions, new.positions, new.velocities, a, np.zeros(world.n, bool)
        )
        state = new
        min_gap = min(min_gap, float(np.min(gap)))
    assert stats.summary().contacts == []
    assert min_gap > 1.0
    np.testing.assert_allclose(state.velocities[idx, 0], 2.0, atol=0.05)  # all queued


def _true_path_error(name: str, seconds: float = 3.0) -> float:
    spec = load_map(name)
    world = World(spec)
    traffic = LaneTraffic.from_map(spec)
    steps = round(seconds / world.dt)
    times = world.dt * np.arange(1, steps + 1)
    state = world.state()
    predicted = traffic.future_paths(state.positions, times)
    actual = []
    for _ in range(steps):
        a = np.zeros((world.n, 2))  # robots stand still, far from the lanes
        a[traffic.indices] = traffic.accelerations(state.positions, state.velocities)
        state = world.step(a)
        actual.append(state.positions[traffic.indices])
    return float(np.max(np.hypot(*(np.array(actual).transpose(1, 0, 2) - predicted).T)))


@pytest.mark.parametrize("name", ["roundabout", "two_lane_road"])
def test_future_path_matches_undisturbed_traffic(name: str) -> None:
    err = _true_path_error(name)
    assert err < PATH_TOL, f"{name}: predicted path off by {err:.4f} m over 3 s"


def test_future_path_is_the_lane_at_cruise_speed() -> None:
    lane = CircleLane((0.0, 0.0), 20.0)
    path = future_path(lane, 3.0, 4.0, np.array([0.0, 1.0, 2.0]))
    np.testing.assert_allclose(path, lane.point_at(np.array([3.0, 7.0, 11.0])))


def test_roundabout_lanes_keep_their_spacing_for_30_s() -> None:
    spec = load_map("roundabout")
    world = World(spec)
    traffic = LaneTraffic.from_map(spec)
    state = world.state()
    for _ in range(300):
        a = np.zeros((world.n, 2))
        a[traffic.indices] = traffic.accelerations(state.positions, state.velocities)
        state = world.step(a)
    speeds = np.hypot(*state.velocities[traffic.indices].T)
    np.testing.assert_allclose(speeds, np.repeat([4.0, 6.0, 8.0], 10), rtol=1e-3)
    for lane, idx in zip(traffic.lanes, traffic.members, strict=True):
        _, lateral = lane.project(state.positions[idx])
        assert np.max(np.abs(lateral)) < 0.02


def test_traffic_does_not_import_maps() -> None:
    """maps builds lanes from traffic; traffic reads a map only through TrafficMap, so the
    two modules do not import each other (not even for type checking): of nao_arena,
    traffic imports only the motion rules (the world's clip), which import only the
    compile decorators (nao_arena.jit), which import only the shared callees' rule
    (nao_arena.shared_code), which imports none of it when it is imported (the manifest's
    type names, inside the functions that run when a kernel compiles or loads)."""
    import ast
    import inspect
    from types import ModuleType

    import nao_arena.jit as jit_module
    import nao_arena.motion as motion_module
    import nao_arena.shared_code as shared_code_module
    import nao_arena.traffic as traffic_module

    def imports(module: ModuleType, top_level: bool = False) -> set[str]:
        tree = ast.parse(inspect.getsource(module))
        nodes = tree.body if top_level else list(ast.walk(tree))
        found = {node.module for node in nodes if isinstance(node, ast.ImportFrom)}
        found |= {a.name for node in nodes if isinstance(node, ast.Import) for a in node.names}
        return {m for m in found if m and m.startswith("nao_arena")}

    assert imports(traffic_module) <= {"nao_arena.motion"}
    assert imports(motion_module) <= {"nao_arena.jit"}
    assert imports(jit_module) == {"nao_arena.shared_code"}
    assert not imports(shared_code_module, top_level=True)


def test_lane_traffic_from_any_traffic_map() -> None:
    """LaneTraffic.from_map needs only what TrafficMap names: a stand-in gives the same."""
    from types import SimpleNamespace

    spec = load_map("roundabout")
    stand_in = SimpleNamespace(bodies=spec.bodies, traffic=spec.traffic, physics=spec.physics)
    a, b = LaneTraffic.from_map(spec), LaneTraffic.from_map(stand_in)
    np.testing.assert_array_equal(a.indices, b.indices)
    state = World(spec).state()
    np.testing.assert_array_equal(
        a.accelerations(state.positions, state.velocities),
        b.accelerations(state.positions, state.velocities),
    )
