"""Map schema, parameters, layout builders and the promised error messages."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from nao_arena.maps import (
    LAYOUTS,
    MapError,
    MapSpec,
    available_maps,
    load_map,
    map_from_dict,
    parse_overrides,
)

BAD = Path(__file__).parent / "bad_maps"
SHIPPED = [
    "circle_swap",
    "circle_swap_perturbed",
    "corridor",
    "crossing",
    "crossing_streams",
    "crossing_streams_perturbed",
    "crowd",
    "crowdnav_circle",
    "crowdnav_square",
    "dense_swap",
    "dense_swap_perturbed",
    "doorway",
    "doorway_perturbed",
    "intersection",
    "intersection_perturbed",
    "pillar_corridor",
    "pillar_corridor_perturbed",
    "roundabout",
    "roundabout_crossing",
    "two_lane_road",
    "warehouse_aisles",
    "warehouse_aisles_perturbed",
]


def test_shipped_maps_are_all_there() -> None:
    assert available_maps() == SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_map_loads(name: str) -> None:
    spec = load_map(name)
    assert isinstance(spec, MapSpec)
    assert spec.name == name
    assert spec.robots, "every shipped map has robots"
    bodies = spec.bodies()
    assert [b.index for b in bodies] == list(range(len(bodies)))
    robots, people = spec.n_robots, spec.n_people
    assert all(b.kind == "robot" for b in bodies[:robots])
    assert all(b.kind == "person" for b in bodies[robots : robots + people])
    assert all(b.kind == "traffic" for b in bodies[robots + people :])
    segs, radii = spec.wall_segments()
    assert segs.shape == (len(radii), 2, 2)


def test_roundabout_is_the_papers_scene() -> None:
    spec = load_map("roundabout")
    assert [g.count for g in spec.traffic] == [10, 10, 10]
    assert sorted(g.lane.radius for g in spec.traffic) == [20.0, 24.0, 28.0]
    assert all(4.0 <= g.speed <= 8.0 and g.radius == 1.0 for g in spec.traffic)
    crossers = [
        r
        for r in spec.robots
        if np.hypot(*r.start) > 28 + 2
        and np.hypot(*r.goal) > 28 + 2
        and np.dot(r.start, r.goal) < 0
        and r.agent == "nao"
        and r.predictor == "known_path"
    ]
    assert crossers


def test_two_lane_road_has_slow_car_ahead_and_oncoming_traffic() -> None:
    spec = load_map("two_lane_road")
    bodies = spec.bodies()
    overtaker = spec.robots[0]
    slow = [b for b in bodies if b.kind == "traffic" and b.velocity[0] > 0]
    oncoming = [b for b in bodies if b.kind == "traffic" and b.velocity[0] < 0]
    assert len(slow) == 1 and len(oncoming) >= 2
    assert slow[0].start[0] > overtaker.start[0]
    assert abs(slow[0].start[1] - overtaker.start[1]) < 1e-9
    assert np.hypot(*slow[0].velocity) < np.hypot(*overtaker.velocity)
    assert all(b.start[1] > 0 for b in oncoming)
    assert len(spec.walls) == 2 and spec.n_robots >= 2


def test_circle_swap_parameters_and_antipodal_goals() -> None:
    spec = load_map("circle_swap", n=16, radius=9.0)
    starts = np.array([r.start for r in spec.robots])
    goals = np.array([r.goal for r in spec.robots])
    assert len(starts) == 16
    np.testing.assert_allclose(np.hypot(*starts.T), 9.0)
    np.testing.assert_allclose(goals, -starts, atol=1e-12)
    assert spec.parameters["n"] == 16


def test_perturbed_starts_are_seeded_and_small() -> None:
    base = load_map("circle_swap")
    a = load_map("circle_swap_perturbed", seed=1)
    b = load_map("circle_swap_perturbed", seed=1)
    c = load_map("circle_swap_perturbed", seed=2)
    sa = np.array([r.start for r in a.robots])
    s0 = np.array([r.start for r in base.robots])
    assert np.array_equal(sa, np.array([r.start for r in b.robots]))
    assert not np.array_equal(sa, np.array([r.start for r in c.robots]))
    shift = np.hypot(*(sa - s0).T)
    assert np.all(shift <= 0.3) and np.all(shift > 0)
    np.testing.assert_allclose([r.goal for r in a.robots], [r.goal for r in base.robots])


def test_crowd_seed_n_and_explicit_generator() -> None:
    a = load_map("crowd", n=30, seed=4)
    b = load_map("crowd", n=30, seed=4)
    c = load_map("crowd", n=30, seed=5)
    d = load_map("crowd", n=30, rng=np.random.default_rng(4))
    starts = [np.array([r.start for r in m.robots]) for m in (a, b, c, d)]
    assert len(starts[0]) == 30
    assert np.array_equal(starts[0], starts[1])
    assert not np.array_equal(starts[0], starts[2])
    assert np.array_equal(starts[0], starts[3])
    lo, hi = np.array(a.bounds.min), np.array(a.bounds.max)
    assert np.all((starts[0] > lo) & (starts[0] < hi))


def _first_attempt_placement(seed: int, n: int, lo: float, hi: float) -> np.ndarray | None:
    """The crowd map's starts and goals (2n, 2) m as its builder drew them at its first
    attempt, before starts were kept where a goal min_travel away fits (radius 0.3 m,
    min_gap 0.2 m, min_travel 4 m, 100000 tries per point; the map's generator); None
    where that drawing found no place."""
    rng = np.random.default_rng(seed)
    box_lo, box_hi, d = np.full(2, lo + 0.5), np.full(2, hi - 0.5), 0.8

    def scatter(avoid: np.ndarray | None) -> np.ndarray | None:
        pts: list[np.ndarray] = []
        for _ in range(100_000):
            p = box_lo + (box_hi - box_lo) * rng.random(2)
            if pts and min(float(np.sum((q - p) ** 2)) for q in pts) < d**2:
                continue
            if avoid is not None and float(np.sum((avoid[len(pts)] - p) ** 2)) < 4.0**2:
                continue
            pts.append(p)
            if len(pts) == n:
                return np.array(pts)
        return None

    starts = scatter(None)
    goals = None if starts is None else scatter(starts)
    return None if goals is None else np.concatenate([starts, goals])


def test_crowd_places_every_seed_of_a_small_region() -> None:
    """Some starts near the middle of a 6 m square have no goal 4 m away within it: the
    first attempt of seeds 17 and 24 found none. Every seed places now; the seeds that
    placed at the first attempt keep their starts and goals."""
    firsts = 0
    for seed in range(30):
        spec = load_map("crowd", n=3, lo=-3.0, hi=3.0, seed=seed)
        starts = np.array([r.start for r in spec.robots])
        goals = np.array([r.goal for r in spec.robots])
        both = np.concatenate([starts, goals])
        assert np.all((both >= -2.5) & (both <= 2.5))
        assert np.all(np.hypot(*(goals - starts).T) >= 4.0)
        for pts in (starts, goals):
            gaps = np.hypot(*(pts[:, None] - pts[None, :]).transpose(2, 0, 1))
            assert np.all(gaps[~np.eye(3, dtype=bool)] >= 0.8)
        first = _first_attempt_placement(seed, 3, -3.0, 3.0)
        if first is not None:
            firsts += 1
            assert np.array_equal(both, first)
    assert firsts < 30  # some seed needed more than the first attempt


def test_crowd_refuses_a_travel_longer_than_the_region() -> None:
    with pytest.raises(MapError, match="min_travel at most the region's diagonal"):
        load_map("crowd", n=2, lo=-1.8, hi=1.8)


def test_crowd_bounds_follow_parameters() -> None:
    spec = load_map("crowd", n=300, lo=-15.0, hi=15.0)
    assert spec.bounds.min == (-15.0, -15.0) and spec.n_robots == 300


def test_layout_robots_get_the_template() -> None:
    spec = load_map("crossing", n=4, agent="goal", predictor="constant_velocity")
    assert spec.n_robots == 8
    assert {r.agent for r in spec.robots} == {"goal"}
    assert {r.predictor for r in spec.robots} == {"constant_velocity"}
    assert spec.robots[0].name == "east0" and spec.robots[4].name == "north0"


def test_parse_overrides_types() -> None:
    assert parse_overrides(["n=20", "speed=5.5", "agent=orca", "flag=true"]) == {
        "n": 20,
        "speed": 5.5,
        "agent": "orca",
        "flag": True,
    }
    with pytest.raises(MapError, match="expected name=value"):
        parse_overrides(["n20"])


def test_override_strings_are_converted() -> None:
    spec = load_map("circle_swap", **parse_overrides(["n=12", "radius=7"]))
    assert spec.n_robots == 12 and spec.parameters["radius"] == 7.0


@pytest.mark.parametrize(
    ("overrides", "path", "expectation"),
    [
        ({"n": "abc"}, "parameters.n", "expected an integer, got 'abc'"),
        ({"n": 2.5}, "parameters.n", "expected an integer"),
        ({"radius": "wide"}, "parameters.radius", "expected a number"),
        ({"m": 3}, "parameters.m", "unknown parameter (declared: n, radius, lo"),
    ],
)
def test_bad_overrides(overrides: dict, path: str, expectation: str) -> None:
    with pytest.raises(MapError) as info:
        load_map("circle_swap", **overrides)
    msg = str(info.value)
    assert "circle_swap.yaml" in msg and path in msg and expectation in msg


def test_unknown_map_name_lists_the_shipped_maps() -> None:
    with pytest.raises(MapError, match="no such map; expected a file path or one of: circle_swap"):
        load_map("nowhere")
    with pytest.raises(MapError, match="no such map file"):
        load_map("missing/file.yaml")


def test_map_from_dict_and_route_goal() -> None:
    spec = map_from_dict(
        {
            "bounds": {"min": [-5, -5], "max": [5, 5]},
            "robots": [{"start": [0, 0], "route": [[1, 1], [2, 2]]}],
        }
    )
    assert spec.robots[0].goal == (2.0, 2.0) and spec.robots[0].name == "robot0"
    assert spec.physics.dt == 0.1 and spec.physics.substeps == 10


def test_layout_registry() -> None:
    assert {"circle_swap", "crowd", "stream"} <= set(LAYOUTS)


# file name -> (field path, expectation): each message must name file, path and expectation
BAD_CASES = {
    "unknown_key.yaml": ("robots[0].colour", "unknown key; expected one of: radius"),
    "wrong_type.yaml": ("robots[0].radius", "expected a number, got 'big'"),
    "negative_radius.yaml": ("robots[2].radius", "expected a positive number, got -1"),
    "start_overlaps_wall.yaml": ("robots[0].start", "overlaps walls[0]"),
    "start_inside_polygon.yaml": ("robots[1].start", "overlaps walls[0]"),
    "start_overlaps_robot.yaml": ("robots[1].start", "overlaps robots[0]"),
    "goal_outside_bounds.yaml": ("robots[0].goal", "expected a point inside the bounds"),
    "route_outside_bounds.yaml": ("robots[0].route[1]", "expected a point inside the bounds"),
    "goal_inside_wall.yaml": ("robots[0].goal", "expected a goal clear of the walls"),
    "lane_vehicles_overlap.yaml": ("traffic[0].spacing", "vehicles 0 and 1 overlap"),
    "lane_vehicle_on_robot.yaml": ("traffic[0] (vehicle 0)", "overlaps robots[0]"),
    "open_lane_too_short.yaml": ("traffic[0].offset", "expected all vehicles within the lane"),
    "open_lane_no_spacing.yaml": ("traffic[0].spacing", "expected a positive number on an open"),
    "missing_bounds.yaml": ("bounds", "required field missing"),
    "bounds_inverted.yaml": ("bounds", "expected max > min"),
    "bad_lane_type.yaml": ("traffic[0].lane", "expected type to be one of 'circle', 'polyline'"),
    "bad_direction.yaml": ("traffic[0].lane.direction", "expected 'ccw' or 'cw', got 'left'"),
    "traffic_vmax_below_speed.yaml": ("traffic[0].v_max", "expected a number greater than speed"),
    "no_goal.yaml": ("robots[0]", "expected a goal or a route"),
    "too_fast.yaml": ("robots[0].velocity", "expected |velocity| <= v_max (1.5), got 3"),
    "point_too_short.yaml": ("walls[0].a", "expected at least 2 items"),
    "nonconvex_polygon.yaml": ("walls[0].points", "expected a convex polygon"),
    "zero_substeps.yaml": ("physics.substeps", "expected a positive number, got 0"),
    "unknown_builder.yaml": (
        "layouts[0].builder",
        "expected one of circle_crossing, circle_swap, crowd, queue, square_crossing, stream",
    ),
    "bad_layout_arg.yaml": ("layouts[0].args.n", "expected a positive number, got -3"),
    "unknown_layout_arg.yaml": ("layouts[0].args.diameter", "unknown key; expected one of: n"),
    "crowd_too_dense.yaml": ("layouts[0]", "cannot place 200 robots"),
    "unknown_parameter_ref.yaml": ("robots[0].radius", "unknown parameter '$rad' (declared: size)"),
    "bad_parameter_value.yaml": ("parameters.n", "expected a number, bool or string"),
    "not_a_mapping.yaml": ("(top level)", "expected a mapping"),
    "invalid_yaml.yaml": ("line 3, column 1", "expected valid YAML"),
    "alias_bomb.yaml": ("line 1, column 4", "an anchor (&name): a map holds plain data"),
    "duplicate_key.yaml": ("line 3, column 56", "the key 'radius' twice in one mapping"),
    "tiny_dt.yaml": ("physics.dt", "expected a number >= 0.001, got 1e-09"),
    "huge_dt.yaml": ("physics.dt", "expected a number <= 1000000.0, got 1e+300"),
    "many_neighbours.yaml": (
        "sensing.max_neighbours",
        "expected a number <= 10000, got 1000000000",
    ),
    "too_many_steps.yaml": (
        "episode.time_limit",
        "expected at most 1000000 control periods "
        "per episode (time_limit / physics.dt), got 5000 s / 0.001 s",
    ),
    "huge_bounds.yaml": ("bounds.min[0]", "expected a number >= -1000000.0, got -1e+300"),
    "deep_nesting.yaml": ("line 1, column 58", "at most 50 levels of nesting"),
    "not_utf8.yaml": ("byte 43", "expected UTF-8 text (invalid start byte)"),
    "wall_without_type.yaml": ("walls[0]", "expected a 'type' key"),
    "robots_not_a_list.yaml": ("robots", "expected a list, got 'abc'"),
    # bounds that keep a map from hanging or exhausting memory
    "huge_iterations.yaml": ("physics.iterations", "expected a number <= 1000, got 2000000000"),
    "huge_substeps.yaml": ("physics.substeps", "expected a number <= 1000, got 100000000"),
    "huge_traffic_count.yaml": ("traffic[0].count", "expected a number <= 10000, got 1000000000"),
    "too_many_bodies.yaml": (
        "traffic[1].count",
        "expected at most 10000 bodies (robots and traffic vehicles) in a "
        "map, got 10001 with this group's vehicles",
    ),
    "huge_layout_n.yaml": ("layouts[0].args.n", "expected a number <= 10000, got 1000000000"),
    "huge_max_tries.yaml": ("layouts[0].args.max_tries", "expected a number <= 1000000"),
    # booleans are not numbers
    "bool_dt.yaml": ("physics.dt", "expected a number, got true"),
    "bool_radius.yaml": ("robots[0].radius", "expected a number, got true"),
    "bool_a_max.yaml": ("robots[0].a_max", "expected a number, got true"),
    "bool_coordinate.yaml": ("robots[0].start[0]", "expected a number, got true"),
    "bool_count.yaml": ("traffic[0].count", "expected an integer, got true"),
    "bool_time_limit.yaml": ("episode.time_limit", "expected a number, got true"),
    "infinite_time_limit.yaml": ("episode.time_limit", "expected a finite number, got inf"),
    "nan_time_limit.yaml": ("episode.time_limit", "expected a finite number, got nan"),
    # names checked when the map loads
    "unknown_agent.yaml": (
        "robots[0].agent",
        "expected one of nao, ao, vo, orca, cbf, goal, lane, social_force, or a name given "
        "with --agent NAME=REFERENCE, got 'superbot'",
    ),
    "unknown_options_agent.yaml": (
        "robots[0].agent_options_for",
        "expected one of nao, ao, vo, orca, cbf, goal, lane, social_force, or a "
        "name given with --agent NAME=REFERENCE, got 'naoo'",
    ),
    "unknown_predictor.yaml": (
        "layouts[0].robot.predictor",
        "expected one of constant_velocity, "
        "constant_acceleration, turn_rate, known_path, shared_plan, got 'crystal_ball'",
    ),
}


def test_every_bad_map_file_has_a_case() -> None:
    assert sorted(p.name for p in BAD.glob("*.yaml")) == sorted(BAD_CASES)


@pytest.mark.parametrize("file", sorted(BAD_CASES))
def test_bad_map_message(file: str) -> None:
    path, expectation = BAD_CASES[file]
    with pytest.raises(MapError) as info:
        load_map(BAD / file)
    msg = str(info.value)
    assert file in msg
    assert f": {path}: " in msg or f": {path} " in msg, msg
    assert expectation in msg, msg
    # a clean error, not a chained traceback from inside the loader
    assert info.value.__suppress_context__ or info.value.__context__ is None


def test_map_error_is_a_value_error() -> None:
    assert issubclass(MapError, ValueError)


# A valid map that sets every numeric field (robots, walls, layouts, traffic, sections).
EVERY_NUMBER: dict = {
    "parameters": {"t": 30.0},
    "bounds": {"min": [-50, -50], "max": [50, 50], "wall_thickness": 0.2},
    "walls": [
        {"type": "segment", "a": [-5, 20], "b": [5, 20], "thickness": 0.2},
        {"type": "polygon", "points": [[30, -40], [32, -40], [32, -38]]},
    ],
    "robots": [
        {
            "start": [0, 0],
            "goal": [1, 1],
            "route": [[1, 1]],
            "velocity": [0.5, 0],
            "radius": 0.3,
            "mass": 1,
            "a_max": 2,
            "v_max": 1.5,
        }
    ],
    "layouts": [
        {
            "builder": "stream",
            "args": {
                "n": 2,
                "origin": [-10, -10],
                "direction": [1, 0],
                "distance": 5,
                "spacing": 1,
                "width": 1,
                "perturb": 0,
            },
            "robot": {"radius": 0.3, "mass": 1, "a_max": 2, "v_max": 1.5},
        },
        {
            "builder": "circle_swap",
            "args": {"n": 3, "radius": 3, "center": [20, 30], "angle": 0.5, "perturb": 0.1},
        },
        {
            "builder": "crowd",
            "args": {
                "n": 2,
                "region_min": [-45, -45],
                "region_max": [-30, -30],
                "min_gap": 0.2,
                "min_travel": 0,
                "max_tries": 1000,
            },
        },
    ],
    "traffic": [
        {
            "lane": {"type": "circle", "center": [0, 0], "radius": 30, "start_angle": 0},
            "speed": 2,
            "count": 2,
            "spacing": 90,
            "offset": 0,
            "phase_jitter": 0,
            "radius": 1,
            "mass": 1000,
            "a_max": 3,
            "v_max": 3,
            "time_headway": 1,
            "min_gap": 2,
        },
        {"lane": {"type": "polyline", "points": [[-40, 45], [40, 45]]}, "speed": 1},
    ],
    "physics": {
        "dt": 0.1,
        "substeps": 10,
        "elasticity": 0.2,
        "friction": 0,
        "collision_slop": 0.005,
        "iterations": 10,
    },
    "episode": {"time_limit": "$t", "goal_tolerance": 0.3},
    "sensing": {"range": 30, "max_neighbours": 5},
}


def _number_paths(node: object, path: str = "") -> list[str]:
    """Paths (as in map errors) of the numbers in node, outside ``parameters``."""
    if isinstance(node, dict):
        return [
            q
            for k, v in node.items()
            if k != "parameters"
            for q in _number_paths(v, f"{path}.{k}".lstrip("."))
        ]
    if isinstance(node, list):
        return [q for i, v in enumerate(node) for q in _number_paths(v, f"{path}[{i}]")]
    return [path] if isinstance(node, int | float) and not isinstance(node, bool) else []


def _replaced(node: object, path: str, value: object, here: str = "") -> object:
    if isinstance(node, dict):
        return {k: _replaced(v, path, value, f"{here}.{k}".lstrip(".")) for k, v in node.items()}
    if isinstance(node, list):
        return [_replaced(v, path, value, f"{here}[{i}]") for i, v in enumerate(node)]
    return value if here == path else node


def test_the_every_number_map_loads() -> None:
    spec = map_from_dict(EVERY_NUMBER)
    assert spec.n_robots == 1 + 2 + 3 + 2 and len(spec.bodies()) == 8 + 3
    assert spec.episode.time_limit == 30.0 and spec.traffic[0].count == 2
    assert len(_number_paths(EVERY_NUMBER)) > 60


@pytest.mark.parametrize("path", _number_paths(EVERY_NUMBER))
@pytest.mark.parametrize("flag", [True, False])
def test_booleans_are_not_numbers(path: str, flag: bool) -> None:
    """true/false is an error wherever a number is expected (it used to read as 1 or 0)."""
    with pytest.raises(MapError) as info:
        map_from_dict(_replaced(EVERY_NUMBER, path, flag), "bools.yaml")
    msg = str(info.value)
    assert msg.startswith(f"bools.yaml: {path}: expected ")
    assert f"got {str(flag).lower()}" in msg, msg


def test_integers_stay_numbers_and_whole_floats_stay_counts() -> None:
    data = _replaced(EVERY_NUMBER, "physics.dt", 1)
    data = _replaced(data, "traffic[0].count", 2.0)
    spec = map_from_dict(data)
    assert spec.physics.dt == 1.0 and isinstance(spec.physics.dt, float)
    assert spec.traffic[0].count == 2 and isinstance(spec.traffic[0].count, int)


@pytest.mark.parametrize("value", [float("inf"), float("nan"), 0.0, -1.0, True])
def test_time_limit_from_a_parameter_is_finite_and_positive(value: float) -> None:
    with pytest.raises(MapError) as info:
        map_from_dict(EVERY_NUMBER, "t.yaml", t=value)
    msg = str(info.value)
    path = "parameters.t" if isinstance(value, bool) else "episode.time_limit"
    assert msg.startswith(f"t.yaml: {path}: expected a "), msg


@pytest.mark.slow
def test_bounds_at_their_caps_load() -> None:
    data = _replaced(EVERY_NUMBER, "physics.substeps", 1000)
    data = _replaced(data, "physics.iterations", 1000)
    data = _replaced(data, "layouts[2].args.max_tries", 1_000_000)
    spec = map_from_dict(data)
    assert (spec.physics.substeps, spec.physics.iterations) == (1000, 1000)
    # 10000 bodies in all: one robot and 9999 vehicles on a long lane
    lane = {"type": "polyline", "points": [[-40, -40], [40, -40]]}
    crowded = {
        "bounds": {"min": [-50, -50], "max": [50, 50]},
        "robots": [{"start": [0, 0], "goal": [1, 1]}],
        "traffic": [{"lane": lane, "speed": 1, "count": 9999, "spacing": 0.008, "radius": 0.003}],
    }
    assert len(map_from_dict(crowded).bodies()) == 10_000


def test_agent_references_and_plugins_pass_the_map_check(monkeypatch) -> None:
    from types import SimpleNamespace

    import nao_arena.agent_names as agent_names

    robot = {"start": [0, 0], "goal": [1, 1]}
    refs = ["path/to/mine.py:Mine", "some.module:Agent", "lane"]
    data = {
        "bounds": {"min": [-9, -9], "max": [9, 9]},
        "robots": [{**robot, "start": [2 * i, 0], "agent": a} for i, a in enumerate(refs)],
    }
    assert [r.agent for r in map_from_dict(data, trusted=True).robots] == refs
    data["robots"].append({**robot, "start": [-4, 0], "agent": "myplug"})
    with pytest.raises(MapError, match=r"robots\[3\]\.agent: expected one of"):
        map_from_dict(data, trusted=True)
    monkeypatch.setattr(
        agent_names, "plugins", lambda: {"myplug": SimpleNamespace(value="pkg.mod:Cls")}
    )
    assert map_from_dict(data, trusted=True).robots[3].agent == "myplug"


@pytest.mark.parametrize("field", ["agent", "agent_options_for"])
@pytest.mark.parametrize("ref", ["subprocess:Popen", "path/to/mine.py:Mine", "os:system"])
def test_a_map_naming_code_is_refused_unless_trusted(field, ref) -> None:
    robot = {"start": [0, 0], "goal": [1, 1], field: ref}
    data = {"bounds": {"min": [-9, -9], "max": [9, 9]}, "robots": [robot]}
    with pytest.raises(MapError) as info:
        map_from_dict(data)
    message = str(info.value)
    assert message.startswith(f"<dict>: robots[0].{field}: expected an agent name")
    assert repr(ref) in message and "--trust-map" in message and "\n" not in message
    assert getattr(map_from_dict(data, trusted=True).robots[0], field) == ref
    # a name the user gave stands for its reference
    robot[field] = "mine"
    named = map_from_dict(data, agents={"mine": ref}).robots[0]
    assert getattr(named, field) == ref
    # through a parameter: the map's own default is refused, the caller's value is not
    data = {
        "bounds": data["bounds"],
        "parameters": {"who": ref},
        "robots": [{**robot, field: "$who"}],
    }
    with pytest.raises(MapError, match="--trust-map"):
        map_from_dict(data)
    assert getattr(map_from_dict(data, who=ref).robots[0], field) == ref


def test_running_a_map_that_names_code_runs_no_code(tmp_path) -> None:
    """The audit's map: a robot whose agent is subprocess:Popen with a shell command."""
    marker = tmp_path / "ran"
    path = tmp_path / "evil.yaml"
    path.write_text(
        "bounds: {min: [-5, -5], max: [5, 5]}\n"
        "robots:\n"
        "  - start: [0, 0]\n"
        "    goal: [1, 1]\n"
        "    agent: 'subprocess:Popen'\n"
        f"    agent_options: {{args: 'touch {marker}', shell: true}}\n"
    )
    from nao_arena.cli import main

    assert main(["run", str(path), "--time-limit", "0.5"]) == 2
    assert not marker.exists()
    # trusted, Popen is still refused before it is constructed: it is no agent class
    assert main(["run", str(path), "--time-limit", "0.5", "--trust-map"]) == 2
    assert not marker.exists()


def test_unknown_agent_from_a_parameter_names_the_field() -> None:
    with pytest.raises(MapError) as info:
        load_map("circle_swap", agent="superbot")
    msg = str(info.value)
    assert msg.startswith("maps/circle_swap.yaml: layouts[0].robot.agent: expected one of nao")


def _scene(spec: MapSpec) -> list[np.ndarray]:
    """A map's start state (every body's position and velocity, traffic phases included)
    and its robots' goals."""
    from nao_arena.world import World

    state = World(spec).reset()
    return [state.positions, state.velocities, np.array([r.goal for r in spec.robots])]


@pytest.mark.parametrize("name", SHIPPED)
def test_a_declared_seed_changes_the_scene(name: str) -> None:
    """A map that declares ``seed`` must vary with it: otherwise a trial's episodes
    would repeat one scene while the seed suggests otherwise."""
    spec = load_map(name)
    if "seed" not in spec.parameters:
        return  # a map without randomness declares no seed (circle_swap, corridor)
    a, b = _scene(load_map(name, seed=0)), _scene(load_map(name, seed=1))
    assert any(x.shape != y.shape or not np.array_equal(x, y) for x, y in zip(a, b, strict=True)), (
        f"{name}: seeds 0 and 1 give one scene"
    )


def test_maps_package_parts_use_only_public_names() -> None:
    """nao_arena.maps is a package (schema, layouts, errors, loader, reference) whose
    modules import no other module's private names; every exported name resolves."""
    import ast
    import importlib

    import nao_arena.maps as maps

    folder = Path(maps.__file__).parent
    assert {p.stem for p in folder.glob("*.py")} >= {
        "__init__",
        "schema",
        "layouts",
        "errors",
        "loader",
        "reference",
    }
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("nao_arena"):
                private = [a.name for a in node.names if a.name.startswith("_")]
                assert not private, f"{path.name} imports {private} from {node.module}"
    for name in maps.__all__:
        assert getattr(maps, name) is not None
    assert importlib.import_module("nao_arena.maps.loader").load_map is maps.load_map


def test_yaml_aliases_are_refused_before_they_expand() -> None:
    """A few hundred bytes of nested aliases (9^9 strings once expanded) are refused at
    their first anchor, not expanded; so are an alias alone and a merge key."""
    with pytest.raises(MapError, match="anchor"):
        load_map(BAD / "alias_bomb.yaml")
    from nao_arena.maps.loader import parse_yaml

    for text in ("a: *x", "a: &x 1\nb: *x", "a: &x {k: 1}\nb: {<<: *x}"):
        with pytest.raises(yaml.YAMLError, match="anchor|alias"):
            parse_yaml(text)
    assert parse_yaml("a: {k: [1, 2]}\nb: 'x'") == {"a": {"k": [1, 2]}, "b": "x"}
    with pytest.raises(yaml.YAMLError, match="twice"):
        parse_yaml("a: 1\nb: 2\na: 3")
    assert parse_yaml("[" * 50 + "]" * 50) is not None
    with pytest.raises(yaml.YAMLError, match="nesting"):
        parse_yaml("[" * 51 + "]" * 51)
