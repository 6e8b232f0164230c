"""The walled scenes: doorway, intersection, warehouse_aisles, pillar_corridor (each with a
seeded ``_perturbed`` variant), their geometry as their descriptions state it, the
``queue`` layout builder they use, and the evidence that they are solvable without contact
and able to fail.

Evidence (marked slow): with every robot driven by ``nao``, on the symmetric map and on
the perturbed one with seeds 0-19, no contact (robot-robot or robot-wall) and every robot
within 0.1 m of its goal at the same time before the map's time limit; with ``goal`` (no
avoidance) at least one contact on every one of those episodes.
Measured when last changed (python benchmarks/scenes_table.py --seeds 20 --agents nao):
NAO all at their goals at once by 55-127 s on doorway_perturbed (70 s symmetric),
26-46 s on intersection_perturbed (26 s), 44-147 s on warehouse_aisles_perturbed (58 s),
35-96 s on pillar_corridor_perturbed (42 s); no contact in any of the 84 episodes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from strategies import floats

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.maps import LAYOUTS, MapError, MapSpec, PolygonWall, load_map, map_from_dict
from nao_arena.maps.layouts import LayoutContext, QueueArgs, StreamArgs, queue, stream
from nao_arena.maps.schema import Bounds
from nao_arena.trials import make_map

SCENES = ["doorway", "intersection", "warehouse_aisles", "pillar_corridor"]
SEEDS = range(20)
TIME_LIMIT = {
    "doorway": 300.0,
    "intersection": 120.0,
    "warehouse_aisles": 180.0,
    "pillar_corridor": 150.0,
}
"""The maps' time limits (s): the stated limits of the evidence."""

# ------------------------------------------------------------------ the queue builder


def _ctx(seed: int = 0) -> LayoutContext:
    return LayoutContext(
        Bounds(min=(-100.0, -100.0), max=(100.0, 100.0)), 0.3, np.random.default_rng(seed)
    )


queue_args = st.fixed_dictionaries(
    {
        "n": st.integers(1, 12),
        "origin": st.tuples(floats(-20, 20), floats(-20, 20)),
        "direction": st.tuples(floats(-1, 1), floats(-1, 1)).filter(
            lambda d: math.hypot(*d) > 1e-3
        ),
        "distance": floats(0.1, 30),
        "spacing": floats(0.1, 3),
        "width": st.integers(1, 4),
        "perturb": st.sampled_from([0.0, 0.1, 0.5]),
    }
)


@given(queue_args, floats(0.1, 3), st.one_of(st.none(), st.integers(1, 4)), st.integers(0, 9))
def test_queue_starts_are_streams_and_its_goals_a_block(args, goal_spacing, goal_width, seed):
    """The starts (and the seeded draws) are exactly ``stream``'s; each goal is its start's
    displacement added to the goal block: goal_width abreast (default width), goal_spacing
    apart, the front row distance ahead of the starts' front row."""
    placed = queue(QueueArgs(**args, goal_spacing=goal_spacing, goal_width=goal_width), _ctx(seed))
    streamed = stream(StreamArgs(**args), _ctx(seed))
    assert [s for s, _ in placed] == [s for s, _ in streamed]
    d = np.asarray(args["direction"]) / math.hypot(*args["direction"])
    nrm = np.array([-d[1], d[0]])
    w = args["width"] if goal_width is None else goal_width
    for k, ((start, goal), (_, stream_goal)) in enumerate(zip(placed, streamed, strict=True)):
        row, col = divmod(k, args["width"])
        unperturbed = (
            np.asarray(args["origin"])
            - row * args["spacing"] * d
            + (col - (args["width"] - 1) / 2) * args["spacing"] * nrm
        )
        shift = np.asarray(start) - unperturbed
        grow, gcol = divmod(k, w)
        block = (
            np.asarray(args["origin"])
            + args["distance"] * d
            - grow * goal_spacing * d
            + (gcol - (w - 1) / 2) * goal_spacing * nrm
        )
        assert np.allclose(goal, block + shift, atol=1e-9)
        if goal_spacing == args["spacing"] and w == args["width"]:
            assert np.allclose(goal, stream_goal, atol=1e-9)


def test_queue_is_registered_and_validates_its_arguments():
    assert LAYOUTS["queue"] == (QueueArgs, queue)
    base = {"bounds": {"min": [-20, -20], "max": [20, 20]}}
    args = {"n": 2, "origin": [0, 0], "direction": [1, 0], "distance": 5, "spacing": 1}
    spec = map_from_dict(
        {
            **base,
            "layouts": [{"builder": "queue", "args": {**args, "goal_spacing": 2, "goal_width": 1}}],
        }
    )
    assert [r.goal for r in spec.robots] == [(5.0, 0.0), (3.0, 0.0)]
    with pytest.raises(MapError, match=r"layouts\[0\]\.args\.goal_spacing: required field"):
        map_from_dict({**base, "layouts": [{"builder": "queue", "args": args}]})
    for key, bad in (("goal_spacing", 0), ("goal_spacing", True), ("goal_width", 0)):
        with pytest.raises(MapError, match=rf"layouts\[0\]\.args\.{key}: expected a"):
            map_from_dict(
                {
                    **base,
                    "layouts": [
                        {"builder": "queue", "args": {**args, "goal_spacing": 2, key: bad}}
                    ],
                }
            )


# ------------------------------------------------------------------ the scenes' geometry


def _wall_surfaces(spec: MapSpec) -> list[tuple[np.ndarray, float]]:
    """Every wall as (segments (k, 2, 2) m, half-thickness m): the map's walls in order,
    then the four bound walls."""
    out = []
    for w in spec.walls:
        if isinstance(w, PolygonWall):
            p = np.asarray(w.points, float)
            out.append((np.stack([p, np.roll(p, -1, axis=0)], axis=1), 0.0))
        else:
            out.append((np.array([[w.a, w.b]], float), w.thickness / 2))
    half = spec.bounds.wall_thickness / 2
    out += [(np.array([seg], float), half) for seg in spec.bound_wall_segments()]
    return out


def _gap(a: tuple[np.ndarray, float], b: tuple[np.ndarray, float]) -> float:
    """Distance (m) between two walls' surfaces (their segments do not cross)."""
    (sa, ha), (sb, hb) = a, b
    ends = min(
        point_segment_distances(sa.reshape(-1, 2), sb).min(),
        point_segment_distances(sb.reshape(-1, 2), sa).min(),
    )
    return float(ends) - ha - hb


def _pairs(spec: MapSpec) -> tuple[np.ndarray, np.ndarray]:
    """Starts and goals (n, 2) m of the map's robots."""
    starts = np.array([r.start for r in spec.robots])
    goals = np.array([r.goal for r in spec.robots])
    return starts, goals


def _same_scene_under(spec: MapSpec, transform) -> None:
    """The map is symmetric under ``transform`` (points (n, 2) -> (n, 2)): walls onto
    walls, (start, goal) pairs onto pairs."""

    def key(points: np.ndarray) -> tuple:
        return tuple(sorted(map(tuple, np.round(points, 9).tolist())))

    walls = {key(np.asarray(w.points, float)) for w in spec.walls}
    assert {key(transform(np.asarray(w.points, float))) for w in spec.walls} == walls
    starts, goals = _pairs(spec)
    pairs = set(
        zip(
            map(tuple, np.round(starts, 9).tolist()),
            map(tuple, np.round(goals, 9).tolist()),
            strict=True,
        )
    )
    moved = set(
        zip(
            map(tuple, np.round(transform(starts), 9).tolist()),
            map(tuple, np.round(transform(goals), 9).tolist()),
            strict=True,
        )
    )
    assert moved == pairs


def _mirror_x(p: np.ndarray) -> np.ndarray:
    return p * np.array([-1.0, 1.0])


def _half_turn(p: np.ndarray) -> np.ndarray:
    return -p


def _quarter_turn(p: np.ndarray) -> np.ndarray:
    return np.stack([-p[:, 1], p[:, 0]], axis=1)


@pytest.mark.parametrize("name", SCENES)
def test_scene_robots_and_episode_are_the_crowd_maps(name):
    """Radius 0.3-0.5 m, a_max 2 m/s^2, v_max 1.5 m/s, dt 0.1 s, arrival within 0.1 m;
    n, agent, predictor and time_limit are parameters, seed and perturb only in the
    perturbed variant."""
    for variant in (name, f"{name}_perturbed"):
        spec = load_map(variant)
        assert spec.physics.dt == 0.1 and spec.episode.goal_tolerance == 0.1
        assert spec.episode.time_limit == TIME_LIMIT[name]
        assert all(
            0.3 <= r.radius <= 0.5 and r.a_max == 2.0 and r.v_max == 1.5 for r in spec.robots
        )
        params = {"n", "agent", "predictor", "time_limit"}
        if variant == name:
            assert set(spec.parameters) == params
        else:
            assert set(spec.parameters) == params | {"perturb", "seed"}
        small = load_map(variant, n=1, agent="orca", predictor="constant_velocity", time_limit=9.0)
        groups = len(spec.robots) // spec.parameters["n"]
        assert len(small.robots) == groups and small.episode.time_limit == 9.0
        assert {(r.agent, r.predictor) for r in small.robots} == {("orca", "constant_velocity")}


@pytest.mark.parametrize("name", SCENES)
def test_perturbed_variant_moves_starts_and_goals_alike_within_perturb(name):
    """perturb 0 gives the symmetric map's robots exactly; any seed moves each start (and
    its goal by the same vector) at most perturb (0.1 m), and seeds differ."""
    sym = load_map(name)
    s0, g0 = _pairs(sym)
    assert [(r.start, r.goal) for r in load_map(f"{name}_perturbed", perturb=0.0).robots] == [
        (r.start, r.goal) for r in sym.robots
    ]
    seen = []
    for seed in (0, 1):
        starts, goals = _pairs(load_map(f"{name}_perturbed", seed=seed))
        shift = starts - s0
        assert np.all(np.hypot(*shift.T) <= 0.1 + 1e-12)
        assert np.allclose(goals - g0, shift, atol=1e-9)
        seen.append(starts)
    assert not np.array_equal(*seen)


def test_doorway_is_a_wall_with_one_gap_of_three_diameters():
    spec = load_map("doorway")
    walls = _wall_surfaces(spec)
    assert _gap(walls[0], walls[1]) == pytest.approx(1.8)  # the gap, between wall faces
    assert 1.8 >= 2.5 * 2 * max(r.radius for r in spec.robots)
    _same_scene_under(spec, _mirror_x)
    starts, goals = _pairs(spec)
    assert len(spec.robots) == 20 and np.all(starts[:, 0] * goals[:, 0] < 0)  # all cross
    assert np.all(np.abs(starts[:, 1]) < 0.9)  # every start in line with the gap
    assert np.all(np.abs(starts[:, 0]) - 0.15 >= 1.85 - 1e-12)  # front 1.85 m from it


def test_intersection_streets_are_4_5_m_wide_and_robots_cross_to_the_opposite_arm():
    spec = load_map("intersection")
    walls = _wall_surfaces(spec)
    buildings = walls[:4]
    across = [_gap(buildings[i], buildings[(i + 1) % 4]) for i in range(4)]
    assert across == pytest.approx([4.5] * 4)
    _same_scene_under(spec, _quarter_turn)
    starts, goals = _pairs(spec)
    assert len(spec.robots) == 16
    # straight across: start and goal on one street's axis side by side, opposite arms
    axis = np.abs(starts).argmax(axis=1)
    rows = np.arange(len(starts))
    assert np.all(starts[rows, axis] * goals[rows, axis] < 0)
    assert np.all(np.abs(goals[rows, 1 - axis]) < 1e-9)  # single file on the far axis


def test_warehouse_aisles_are_1_8_m_wide_with_traffic_both_ways_in_each():
    spec = load_map("warehouse_aisles")
    walls = _wall_surfaces(spec)
    shelves = walls[:5]
    aisles = [_gap(shelves[i], shelves[i + 1]) for i in range(4)]
    assert aisles == pytest.approx([1.8] * 4)
    assert all(_gap(shelf, walls[-1]) == pytest.approx(4.9) for shelf in shelves)  # west
    _same_scene_under(spec, _mirror_x)
    starts, goals = _pairs(spec)
    for y in (-4.2, -1.4, 1.4, 4.2):
        here = np.isclose(starts[:, 1], y)
        east = here & (starts[:, 0] < -6.0) & (goals[:, 0] > 6.0)
        west = here & (starts[:, 0] > 6.0) & (goals[:, 0] < -6.0)
        assert east.sum() == west.sum() == 2


def test_pillar_corridor_pillars_leave_room_for_two_way_flow():
    spec = load_map("pillar_corridor")
    walls = _wall_surfaces(spec)
    pillars, bounds = walls[:6], walls[6:]
    assert min(_gap(p, b) for p in pillars for b in bounds) == pytest.approx(1.55)
    between = [_gap(pillars[i], pillars[i + 1]) for i in range(5)]
    assert min(between) >= 2.0
    assert all(np.ptp(np.asarray(w.points)[:, 0]) == pytest.approx(0.7) for w in spec.walls)
    _same_scene_under(spec, _half_turn)
    starts, goals = _pairs(spec)
    assert len(spec.robots) == 12 and np.all(starts[:, 0] * goals[:, 0] < 0)


# ------------------------------------------------------------------ the evidence

EPISODES = [(name, 0) for name in SCENES] + [
    (f"{name}_perturbed", seed) for name in SCENES for seed in SEEDS
]


def _scene(name: str) -> str:
    return name.removesuffix("_perturbed")


def _run(name: str, seed: int, agent: str):
    arena = Arena(
        make_map(name, seed, {"time_limit": TIME_LIMIT[_scene(name)]}), ArenaOptions(agent=agent)
    )
    return arena, arena.run(seed=seed)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "seed"), EPISODES)
def test_nao_robots_all_reach_their_goals_at_once_without_contact(name, seed):
    arena, summary = _run(name, seed, "nao")
    assert list(summary.contacts) == []  # neither robot-robot nor robot-wall
    assert arena.time < TIME_LIMIT[_scene(name)]  # ended: every robot at its goal at once
    assert all(r.at_goal_at_end and r.success for r in summary.robots)
    assert all(r.final_goal_distance <= 0.1 for r in summary.robots)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "seed"), EPISODES)
def test_goal_seeking_without_avoidance_collides_on_the_same_episodes(name, seed):
    _, summary = _run(name, seed, "goal")
    assert len(summary.contacts) > 0
