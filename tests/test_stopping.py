"""Stopping plans: the plan is the path the world drives, its clearance is exact, and the
rule keeps robots apart in the world even when their desired accelerations would collide."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.maps import MapSpec, map_from_dict
from nao_arena.stopping import _largest, commit_plans, plan_clearance, stopping_plan
from nao_arena.world import World

DT, SUBSTEPS, A_MAX, V_MAX, RADIUS = 0.1, 10, 2.0, 1.5, 0.5


def robots_map(
    starts: np.ndarray,
    goals: np.ndarray,
    velocities: np.ndarray | None = None,
    walls: list[dict] | None = None,
) -> MapSpec:
    robots = [
        {
            "start": list(map(float, s)),
            "goal": list(map(float, g)),
            "velocity": [0.0, 0.0] if velocities is None else list(map(float, v)),
            "radius": RADIUS,
            "a_max": A_MAX,
            "v_max": V_MAX,
        }
        for s, g, v in zip(
            starts, goals, velocities if velocities is not None else starts, strict=True
        )
    ]
    return map_from_dict(
        {
            "bounds": {"min": [-100, -100], "max": [100, 100]},
            "robots": robots,
            "walls": walls or [],
            "physics": {"dt": DT, "substeps": SUBSTEPS},
        }
    )


def brake_accel(v: np.ndarray) -> np.ndarray:
    """The standing plan's acceleration: -min(a_max, |v| / dt) v / |v| per row."""
    speed = np.hypot(v[:, 0], v[:, 1])
    k = np.where(speed > 0, np.minimum(A_MAX, speed / DT) / np.maximum(speed, 1e-300), 0.0)
    return -v * k[:, None]


def min_gaps(sub: np.ndarray) -> np.ndarray:
    """Per pair (i, j), the smallest centre distance (m) within one period of substep
    positions sub (S + 1, n, 2), the bodies moving straight between substeps; (n, n)."""
    d = sub[:, :, None, :] - sub[:, None, :, :]  # (S + 1, n, n, 2)
    a, b = d[:-1], d[1:]
    e = b - a
    ee = np.sum(e * e, axis=-1)
    t = np.clip(-np.sum(a * e, axis=-1) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    t = np.where(ee > 0, t, 0.0)
    p = a + t[..., None] * e
    gaps = np.sqrt(np.min(np.sum(p * p, axis=-1), axis=0))
    np.fill_diagonal(gaps, np.inf)
    return gaps


def test_plan_is_the_path_the_world_drives() -> None:
    """Each robot drives its command, then the standing plan's braking, period by period:
    the world's substep positions equal the plan's to 1e-9 m (some robots start at
    v_max and saturate, some commands exceed a_max)."""
    rng = np.random.default_rng(3)
    n = 12
    starts = np.stack([np.arange(n) * 15.0 - 80.0, np.zeros(n)], axis=1)
    v0 = rng.uniform(-1.0, 1.0, (n, 2))
    v0[:4] *= V_MAX / np.hypot(v0[:4, 0], v0[:4, 1])[:, None]  # at the speed limit
    world = World(robots_map(starts, starts, v0))
    world.reset()
    pos, vel = world.positions.copy(), world.velocities.copy()
    accel = rng.uniform(-3.0, 3.0, (n, 2))
    plans = [stopping_plan(pos[i], vel[i], accel[i], A_MAX, V_MAX, DT, SUBSTEPS) for i in range(n)]
    driven = [pos[None].copy()]
    command = accel
    for _ in range(12):
        world.step(command)
        driven.append(world.substep_positions[1:].copy())
        command = brake_accel(world.velocities)
    path = np.concatenate(driven)  # (periods * substeps + 1, n, 2)
    for i in range(n):
        p = plans[i]
        assert len(p) < len(path)
        np.testing.assert_allclose(path[: len(p), i], p, atol=1e-9)
        # after the plan ends the robot stands at its last point
        np.testing.assert_allclose(
            path[len(p) :, i], np.broadcast_to(p[-1], path[len(p) :, i].shape), atol=1e-9
        )
    assert np.all(np.hypot(*world.velocities.T) < 1e-9)


finite = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(st.lists(finite, min_size=10, max_size=10))
def test_plan_clearance_is_the_sampled_minimum(u: list[float]) -> None:
    """The clearance of two plans against the distance sampled 200 times per substep:
    never above it, and below it by no more than the sampling's resolution."""
    x = np.array(u)
    p_a, p_b = np.array([0.0, 0.0]), np.array([2.5 * x[0], 2.5 * x[1]])
    v_a, v_b = V_MAX * x[2:4] / math.sqrt(2), V_MAX * x[4:6] / math.sqrt(2)
    a_a, a_b = 3.0 * x[6:8], 3.0 * x[8:10]
    plan_a = stopping_plan(p_a, v_a, a_a, A_MAX, V_MAX, DT, SUBSTEPS)
    plan_b = stopping_plan(p_b, v_b, a_b, A_MAX, V_MAX, DT, SUBSTEPS)
    n = max(len(plan_a), len(plan_b))
    pa = np.concatenate([plan_a, np.repeat(plan_a[-1:], n - len(plan_a), axis=0)])
    pb = np.concatenate([plan_b, np.repeat(plan_b[-1:], n - len(plan_b), axis=0)])
    rel = pa - pb
    s = np.linspace(0.0, 1.0, 201)[:, None, None]
    dense = rel[:-1][None] + s * (rel[1:] - rel[:-1])[None]
    sampled = float(np.min(np.hypot(dense[..., 0], dense[..., 1])))
    step = float(np.max(np.hypot(*(rel[1:] - rel[:-1]).T))) / 200
    got = plan_clearance(plan_a, plan_b, SUBSTEPS)
    assert got <= sampled + 1e-12
    assert got >= sampled - step - 1e-12


def reference_rule(
    pos: np.ndarray, vel: np.ndarray, desired: np.ndarray, margin: float
) -> np.ndarray:
    """The rule written plainly: every pair by exact plan clearance, robots switching to
    braking in robot order until nothing conflicts."""
    n = len(pos)
    want = [stopping_plan(pos[i], vel[i], desired[i], A_MAX, V_MAX, DT, SUBSTEPS) for i in range(n)]
    stand = [
        stopping_plan(pos[i], vel[i], brake_accel(vel[i : i + 1])[0], A_MAX, V_MAX, DT, SUBSTEPS)
        for i in range(n)
    ]
    brake = np.zeros(n, dtype=bool)
    changed = True
    while changed:
        changed = False
        for i in range(n):
            if brake[i]:
                continue
            for j in range(n):
                if (
                    j != i
                    and plan_clearance(want[i], stand[j] if brake[j] else want[j], SUBSTEPS)
                    < 2 * RADIUS + margin
                ):
                    brake[i] = changed = True
                    break
    return brake


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(2, 14))
def test_commit_matches_the_plain_rule_and_leaves_plans_clear(seed: int, n: int) -> None:
    """Random groups (crowded, moving, desired accelerations anywhere): the compiled rule
    brakes exactly the robots the plain rule does, and whenever the standing plans were
    clear, every pair of final plans is clear."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-3.0, 3.0, (n, 2))
    vel = rng.uniform(-1.0, 1.0, (n, 2))
    desired = rng.uniform(-2.5, 2.5, (n, 2))
    margin = 0.01
    ones = np.ones(n)
    brake, braking = commit_plans(
        pos, vel, desired, RADIUS * ones, A_MAX * ones, V_MAX * ones, DT, SUBSTEPS, margin
    )
    np.testing.assert_allclose(braking, brake_accel(vel), rtol=1e-15, atol=1e-15)
    np.testing.assert_array_equal(brake, reference_rule(pos, vel, desired, margin))
    stand = [
        stopping_plan(pos[i], vel[i], brake_accel(vel[i : i + 1])[0], A_MAX, V_MAX, DT, SUBSTEPS)
        for i in range(n)
    ]
    final = [
        stand[i]
        if brake[i]
        else stopping_plan(pos[i], vel[i], desired[i], A_MAX, V_MAX, DT, SUBSTEPS)
        for i in range(n)
    ]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    if all(plan_clearance(stand[i], stand[j], SUBSTEPS) >= 2 * RADIUS + margin for i, j in pairs):
        for i, j in pairs:
            assert plan_clearance(final[i], final[j], SUBSTEPS) >= 2 * RADIUS + margin


def run_goal_seekers(spec: MapSpec, with_rule: bool, periods: int) -> float:
    """Smallest centre distance (m) over an episode of proportional goal seekers, with or
    without the rule, measured on the world's substep path."""
    world = World(spec)
    world.reset()
    goals = np.array([r.goal for r in spec.robots], float)
    n = len(goals)
    ones = np.ones(n)
    walls, half = spec.wall_segments()
    closest = math.inf
    for _ in range(periods):
        pos, vel = world.positions.copy(), world.velocities.copy()
        to_goal = goals - pos
        dist = np.hypot(*to_goal.T)
        speed = np.minimum(V_MAX, np.sqrt(A_MAX * dist))
        desired = (to_goal / np.maximum(dist, 1e-9)[:, None] * speed[:, None] - vel) / 0.3
        command = desired
        if with_rule:
            brake, braking = commit_plans(
                pos,
                vel,
                desired,
                RADIUS * ones,
                A_MAX * ones,
                V_MAX * ones,
                DT,
                SUBSTEPS,
                0.005,
                walls,
                half,
            )
            command = np.where(brake[:, None], braking, desired)
        world.step(command)
        sub = world.substep_positions
        closest = min(closest, float(np.min(min_gaps(sub))))
        for seg, h in zip(walls, half, strict=True):
            closest = min(closest, wall_gap(sub, seg) - h + RADIUS)
    return closest


def wall_gap(sub: np.ndarray, seg: np.ndarray) -> float:
    """Smallest distance (m) from the segment seg (2, 2) to the bodies' substep paths
    (sub (S + 1, n, 2)), sampled 50 times per substep (a lower bound on it to within
    the sampling's resolution is all the test needs: it asserts a gap)."""
    s = np.linspace(0.0, 1.0, 51)[:, None, None, None]
    pts = (sub[:-1][None] + s * (sub[1:] - sub[:-1])[None]).reshape(-1, 2)
    a, b = seg
    e = b - a
    t = np.clip((pts - a) @ e / max(float(e @ e), 1e-300), 0.0, 1.0)
    return float(np.min(np.hypot(*(pts - (a + t[:, None] * e)).T)))


def test_non_finite_input_brakes_nobody() -> None:
    """A non-finite position, velocity or desired acceleration anywhere in the group: no
    robot is told to brake and the braking accelerations stay zero (the arena rejects
    such input before it reaches the world); an empty group is empty."""
    pos = np.array([[0.0, 0.0], [1.2, 0.0]])
    vel = np.array([[1.0, 0.0], [-1.0, 0.0]])
    desired = np.array([[2.0, 0.0], [-2.0, 0.0]])  # head-on: both plans meet
    ones = np.ones(2)
    args = (RADIUS * ones, A_MAX * ones, V_MAX * ones, DT, SUBSTEPS, 0.01)
    assert commit_plans(pos, vel, desired, *args)[0].any()
    for which, bad in (("pos", math.nan), ("vel", math.inf), ("desired", math.nan)):
        arrays = {"pos": pos.copy(), "vel": vel.copy(), "desired": desired.copy()}
        arrays[which][1, 0] = bad
        brake, braking = commit_plans(arrays["pos"], arrays["vel"], arrays["desired"], *args)
        assert not brake.any() and not braking.any(), which
    empty = commit_plans(
        np.zeros((0, 2)),
        np.zeros((0, 2)),
        np.zeros((0, 2)),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        DT,
        SUBSTEPS,
        0.01,
    )
    assert empty[0].shape == (0,) and empty[1].shape == (0, 2)


def test_rule_keeps_colliding_goal_seekers_apart_in_the_world() -> None:
    """Eight goal seekers swap places across a circle (no avoidance at all): without the
    rule they collide; with it, no two centres ever come within 2 r in the world."""
    n = 8
    ang = 2 * np.pi * np.arange(n) / n
    starts = 4.0 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    spec = robots_map(starts, -starts)
    assert run_goal_seekers(spec, False, 80) < 2 * RADIUS - 0.01
    assert run_goal_seekers(spec, True, 150) >= 2 * RADIUS


def test_rule_keeps_goal_seekers_off_a_wall() -> None:
    """Goal seekers drive at full speed toward goals behind a thin wall: without the rule
    they hit it; with it, none comes within its radius of the wall (plus its half
    thickness) in the world."""
    starts = np.array([[-6.0, y] for y in (-3.0, -1.0, 1.0, 3.0)])
    goals = starts + np.array([12.0, 0.0])
    walls = [{"type": "segment", "a": [0.0, -5.0], "b": [0.0, 5.0], "thickness": 0.2}]
    spec = robots_map(starts, goals, walls=walls)
    assert run_goal_seekers(spec, False, 80) < 2 * RADIUS - 0.01
    assert run_goal_seekers(spec, True, 80) >= 2 * RADIUS - 1e-3


def short_sighted_swap(stopping_plans: bool):
    """30 nao robots on the perturbed swap with a 0.3 s horizon and no margin: avoidance
    that sees too little to keep them apart on its own."""
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    options = ArenaOptions(
        agent_options={"horizon": 0.3, "margin": 0.0, "stopping_plans": stopping_plans}
    )
    arena = Arena(load_map("dense_swap_perturbed", n=30, time_limit=120.0), options)
    summary = arena.run(seed=0)
    return arena, summary


def test_nao_robots_with_stopping_plans_never_touch_even_when_short_sighted() -> None:
    """Without stopping plans the short-sighted robots touch; with them, none does (the
    closest pair keeps the plans' margin), robots yield, and all still arrive at once."""
    from nao_arena.agents.nao import PLAN_MARGIN

    _, blind = short_sighted_swap(False)
    assert len(blind.contacts) > 0
    arena, summary = short_sighted_swap(True)
    assert summary.contacts == []
    assert min(r.min_separation for r in summary.robots) >= PLAN_MARGIN - 1e-9
    assert all(r.at_goal_at_end for r in summary.robots)
    assert summary.duration < 120.0


def test_a_yield_is_recorded_in_the_episode_log(tmp_path) -> None:
    """The short-sighted swap's yields reach the episode log as status "yielded"."""
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.episode_log import EpisodeRecorder, read_log, write_log
    from nao_arena.maps import load_map

    options = ArenaOptions(agent_options={"horizon": 0.3, "margin": 0.0})
    arena = Arena(load_map("dense_swap_perturbed", n=30, time_limit=120.0), options)
    arena.recorder = EpisodeRecorder()
    arena.run(seed=0, max_steps=200)
    log = read_log(write_log(arena.recorder.finish(), tmp_path / "swap.parquet"))
    statuses = {log.status_of(step, robot) for step in range(1, log.n_steps) for robot in range(30)}
    assert "yielded" in statuses


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.sampled_from([math.nan, -math.inf, math.inf, -0.0, 0.0, 0.5, 1.0, 2.5, 1e300]),
        min_size=1,
        max_size=20,
    )
)
def test_largest_is_the_compiled_np_max(values):
    # numba's np.max, which _near_pairs used: NaN if any, else the first of the largest
    # (so -0.0 before 0.0, as Python's max; numpy itself may return either zero)
    got = _largest(np.array(values))
    if any(math.isnan(v) for v in values):
        assert math.isnan(got)
    else:
        expected = max(values)
        assert got == expected and math.copysign(1.0, got) == math.copysign(1.0, expected)
