"""The pymunk world: limits, the speed-limit model, contacts, determinism, shipped maps."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from reference.world_reference import substep_weights, velocity_after_period

from nao_arena.maps import MapSpec, available_maps, load_map, map_from_dict
from nao_arena.stats import EpisodeStats
from nao_arena.traffic import LaneTraffic
from nao_arena.world import World, speed_limit_time

# Tolerances stated: limits hold to 1e-9 relative; the period model to 1e-12 m/s.
LIMIT_RTOL = 1e-9
MODEL_ATOL = 1e-12


def spread_map(
    n: int,
    v_max: float = 1.5,
    a_max: float = 2.0,
    spacing: float = 100.0,
    velocities: np.ndarray | None = None,
    substeps: int = 10,
) -> MapSpec:
    """n robots on a wide grid: they never meet within a short run."""
    side = int(np.ceil(np.sqrt(n)))
    robots = []
    for k in range(n):
        start = [spacing * (k % side), spacing * (k // side)]
        v = [0.0, 0.0] if velocities is None else list(velocities[k])
        robots.append(
            {
                "start": start,
                "goal": start,
                "velocity": v,
                "radius": 0.5,
                "a_max": a_max,
                "v_max": v_max,
            }
        )
    return map_from_dict(
        {
            "bounds": {"min": [-1000, -1000], "max": [2000, 2000]},
            "robots": robots,
            "physics": {"dt": 0.1, "substeps": substeps},
        }
    )


def goal_seeking(spec: MapSpec, world: World, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
    """Proportional goal seeking for the bodies agents drive (rows 0..R-1: the robots,
    then the people), m/s^2."""
    n = len(spec.robots)
    goals = np.array([r.goal for r in spec.robots], float).reshape(-1, 2)
    to_goal = goals - pos[:n]
    dist = np.hypot(*to_goal.T)
    speed = np.minimum(world.v_max[:n], np.sqrt(world.a_max[:n] * dist))
    v_target = to_goal / np.maximum(dist, 1e-9)[:, None] * speed[:, None]
    return (v_target - vel[:n]) / 0.5


# ---------------------------------------------------------------- the speed-limit model


def test_speed_limit_time_is_the_positive_root() -> None:
    rng = np.random.default_rng(0)
    v = rng.normal(size=(500, 2))
    v_max = np.hypot(*v.T) + rng.uniform(0.0, 2.0, 500)
    a = rng.normal(size=(500, 2)) * 3
    tau = speed_limit_time(v, a, v_max)
    assert np.all(tau > 0)
    np.testing.assert_allclose(np.hypot(*(v + a * tau[:, None]).T), v_max, rtol=1e-12)


def test_speed_limit_time_at_vmax() -> None:
    v = np.array([[1.5, 0.0], [1.5, 0.0], [1.5, 0.0], [0.0, 0.0]])
    a = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, 0.0]])
    tau = speed_limit_time(v, a, np.full(4, 1.5))
    assert tau[0] == 0.0 and tau[1] == 0.0  # no speed gained, not even sideways
    assert tau[2] == pytest.approx(3.0)  # braking: back to v_max after 3 s
    assert tau[3] == np.inf


def test_substep_weights_integrate_to_min_tau_dt() -> None:
    tau = np.array([0.0, 0.013, 0.05, 0.1, 0.37, np.inf])
    w = substep_weights(tau, 0.1, 10)
    np.testing.assert_allclose(w.sum(axis=0) * 0.01, np.minimum(tau, 0.1), atol=1e-15)


def test_velocity_after_period_matches_world() -> None:
    rng = np.random.default_rng(1)
    n = 60
    v_max = 1.5
    v0 = rng.normal(size=(n, 2))
    v0 *= np.minimum(1.0, v_max / np.hypot(*v0.T))[:, None]
    v0[:10] *= v_max / np.hypot(*v0[:10].T)[:, None]  # some exactly at v_max
    world = World(spread_map(n, v_max=v_max, velocities=v0))
    for _ in range(20):
        before = world.state()
        a = rng.normal(size=(n, 2)) * 3.0
        after = world.step(a)
        expected = velocity_after_period(before.velocities, a, world.a_max, world.v_max, 0.1)
        np.testing.assert_allclose(after.velocities, expected, rtol=0, atol=MODEL_ATOL)
        np.testing.assert_array_equal(
            after.accelerations, (after.velocities - before.velocities) / 0.1
        )


def test_speed_saturates_then_coasts() -> None:
    world = World(spread_map(1, v_max=1.0, a_max=2.0, velocities=np.array([[0.95, 0.0]])))
    state = world.step(np.array([[2.0, 0.0]]))
    # accelerates 0.025 s at 2 m/s^2, then coasts at 1 m/s
    assert state.velocities[0, 0] == pytest.approx(1.0, abs=1e-12)
    assert state.accelerations[0, 0] == pytest.approx(0.5, abs=1e-9)


def test_limits_hold_on_random_commands() -> None:
    rng = np.random.default_rng(2)
    n = 25
    world = World(spread_map(n, v_max=1.5, a_max=2.0))
    max_v = max_a = 0.0
    for _ in range(200):
        cmd = rng.normal(size=(n, 2)) * rng.choice([0.5, 3.0, 30.0])
        state = world.step(cmd)
        max_v = max(max_v, float(np.max(np.hypot(*state.velocities.T))))
        max_a = max(max_a, float(np.max(np.hypot(*state.accelerations.T))))
    assert max_v <= 1.5 * (1 + LIMIT_RTOL), max_v
    assert max_a <= 2.0 * (1 + LIMIT_RTOL), max_a
    assert max_v > 1.49  # the run did reach the limit


def test_applied_accelerations_are_the_clipped_commands_bit_for_bit() -> None:
    """World.applied_accelerations: the last step's commands scaled to |a| <= a_max, the
    bits of clip_accelerations (and of applied_plans); zeros and read-only after a reset,
    unchanged by a step that rejects its input."""
    from nao_arena.world import applied_plans, clip_accelerations

    rng = np.random.default_rng(5)
    n = 12
    world = World(spread_map(n, v_max=1.5, a_max=2.0))
    assert np.all(world.applied_accelerations == 0.0)
    assert not world.applied_accelerations.flags.writeable
    rows = np.arange(n, dtype=np.int64)
    for _ in range(20):
        cmd = rng.normal(size=(n, 2)) * rng.choice([0.0, 1e-310, 0.5, 3.0, 1e6], (n, 1))
        world.step(cmd)
        got = world.applied_accelerations
        assert not got.flags.writeable
        assert got.tobytes() == clip_accelerations(cmd, world.a_max).tobytes()
        assert got.tobytes() == applied_plans(cmd, rows, world.a_max, n).tobytes()
    before = world.applied_accelerations.copy()
    with pytest.raises(ValueError, match="finite"):
        world.step(np.full((n, 2), np.nan))
    assert world.applied_accelerations.tobytes() == before.tobytes()
    world.reset()
    assert np.all(world.applied_accelerations == 0.0)


def test_speed_limit_holds_through_contacts() -> None:
    spec = load_map("crowd", n=40, lo=-5.0, hi=5.0, seed=3)
    world = World(spec)
    rng = np.random.default_rng(3)
    for _ in range(150):
        state = world.step(rng.normal(size=(world.n, 2)) * 5.0)
        assert np.all(np.hypot(*state.velocities.T) <= world.v_max * (1 + LIMIT_RTOL))


def test_contact_overspeed_is_scaled_not_teleported() -> None:
    spec = map_from_dict(
        {
            "bounds": {"min": [-50, -50], "max": [50, 50]},
            "robots": [
                {
                    "start": [-3, 0],
                    "goal": [10, 0],
                    "velocity": [4, 0],
                    "radius": 0.5,
                    "mass": 50.0,
                    "a_max": 1.0,
                    "v_max": 4.0,
                },
                {
                    "start": [0, 0],
                    "goal": [-10, 0],
                    "radius": 0.5,
                    "mass": 1.0,
                    "a_max": 1.0,
                    "v_max": 0.5,
                },
            ],
            "physics": {"elasticity": 1.0},
        }
    )
    world = World(spec)
    prev = world.state()
    for _ in range(20):
        state = world.step(np.zeros((2, 2)))
        assert np.hypot(*state.velocities[1]) <= 0.5 * (1 + LIMIT_RTOL)
        # no jump: within a step it moves at most as fast as an elastic kick from the
        # heavy robot allows (2 x 4 m/s), however fast it is reported afterwards
        assert np.hypot(*(state.positions[1] - prev.positions[1])) <= 8.0 * 0.1 + 1e-9
        prev = state
    assert state.positions[1, 0] > 0.5  # it was pushed


def test_overspeed_is_scaled_back_and_gains_no_speed() -> None:
    v = np.array([[3.0, 0.0], [3.0, 0.0], [3.0, 0.0]])
    a = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    out = velocity_after_period(v, a, np.full(3, 2.0), np.full(3, 1.5), 0.1)
    np.testing.assert_allclose(out[0], [1.5, 0.0])  # scaled, no forward push
    np.testing.assert_allclose(out[1], [1.5, 0.0])  # no sideways speed gain at v_max
    np.testing.assert_allclose(out[2], [1.4, 0.0])  # braking still works


# ---------------------------------------------------------------- walls, order, reset


def test_walls_stop_robots() -> None:
    spec = map_from_dict(
        {
            "bounds": {"min": [-5, -5], "max": [5, 5], "walls": True},
            "walls": [{"type": "polygon", "points": [[1, -1], [2, -1], [2, 1], [1, 1]]}],
            "robots": [
                {"start": [0, 0], "goal": [4, 0], "v_max": 3.0, "a_max": 5.0},
                {"start": [0, 3], "goal": [0, 4.5], "v_max": 3.0, "a_max": 5.0},
            ],
        }
    )
    world = World(spec)
    for _ in range(100):
        state = world.step(np.array([[5.0, 0.0], [0.0, 5.0]]))
    assert state.positions[0, 0] < 1.0 - 0.3 + 0.02  # held by the polygon's face
    assert state.positions[1, 1] < 5.0 - 0.1 - 0.3 + 0.02  # held by the bound wall


def test_body_order_kinds_and_names() -> None:
    spec = load_map("roundabout")
    world = World(spec)
    state = world.state()
    assert state.kinds == ("robot",) * 2 + ("traffic",) * 30
    assert state.names[:2] == ("west_east", "south_north")
    assert state.names[2] == "inner_0"
    np.testing.assert_array_equal(state.positions, [b.start for b in spec.bodies()])
    np.testing.assert_array_equal(state.velocities, [b.velocity for b in spec.bodies()])
    assert list(world.robot_indices) == [0, 1]
    assert len(world.traffic_indices) == 30


def test_reset_builds_a_fresh_space_and_repeats_the_run() -> None:
    world = World(load_map("crowd", n=20, seed=1))
    rng = np.random.default_rng(0)
    cmds = rng.normal(size=(50, 20, 2)) * 2
    first_space = world._space
    run1 = np.array([world.step(c).positions for c in cmds])
    state = world.reset()
    assert world._space is not first_space
    assert state.time == 0.0 and np.all(state.accelerations == 0)
    run2 = np.array([world.step(c).positions for c in cmds])
    assert np.array_equal(run1, run2)


def test_step_checks_its_input() -> None:
    world = World(load_map("circle_swap"))
    with pytest.raises(ValueError, match="shape"):
        world.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        world.step(np.full((10, 2), np.nan))


def test_previous_positions_and_time() -> None:
    world = World(load_map("circle_swap"))
    before = world.state()
    after = world.step(np.ones((10, 2)))
    np.testing.assert_array_equal(world.previous_positions, before.positions)
    assert after.time == pytest.approx(0.1)
    for _ in range(9):
        after = world.step(np.zeros((10, 2)))
    assert after.time == 1.0


# ---------------------------------------------------------------- determinism

RUN_SCRIPT = textwrap.dedent(
    """
    import hashlib, sys
    import numpy as np
    from nao_arena.maps import load_map
    from nao_arena.traffic import LaneTraffic
    from nao_arena.world import World
    out = hashlib.sha256()
    for name in ("roundabout", "crowd"):
        spec = load_map(name, seed=7) if name == "crowd" else load_map(name)
        world = World(spec)
        traffic = LaneTraffic.from_map(spec)
        rng = np.random.default_rng(11)
        state = world.state()
        for _ in range(60):
            a = rng.normal(size=(world.n, 2)) * 3.0
            if len(traffic.indices):
                a[traffic.indices] = traffic.accelerations(state.positions, state.velocities)
            state = world.step(a)
            out.update(state.positions.tobytes())
            out.update(state.velocities.tobytes())
    sys.stdout.write(out.hexdigest())
    """
)


def _run_digest(hashseed: str) -> str:
    env = {**os.environ, "PYTHONHASHSEED": hashseed}
    # run from the tests folder: from the repository root, ``-c`` would import the
    # source tree instead of the installed package
    res = subprocess.run(
        [sys.executable, "-c", RUN_SCRIPT],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        cwd=os.path.dirname(os.path.abspath(__file__)),
    )
    return res.stdout.strip()


def test_same_commands_give_identical_arrays() -> None:
    def run() -> tuple[np.ndarray, np.ndarray]:
        spec = load_map("crowd", n=40, lo=-6.0, hi=6.0, seed=5)
        world = World(spec)
        rng = np.random.default_rng(9)
        pos, vel = [], []
        for _ in range(100):
            s = world.step(rng.normal(size=(world.n, 2)) * 4.0)
            pos.append(s.positions)
            vel.append(s.velocities)
        return np.array(pos), np.array(vel)

    p1, v1 = run()
    p2, v2 = run()
    assert np.array_equal(p1, p2) and np.array_equal(v1, v2)


def test_compiled_substeps_are_pymunks_own_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled substep loop (straight into chipmunk) and the loop through
    ``Space.step`` give the same trajectories bit for bit, in a crowd with contacts and
    walls; the compiled loop is the one that runs once pymunk is idle."""
    import nao_arena.world as world_module

    compiled = world_module._direct_period
    calls = [0]

    def counted(*args: object) -> object:
        calls[0] += 1
        return compiled(*args)

    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        spec = load_map("crowd", n=40, lo=-6.0, hi=6.0, seed=5)
        world = World(spec)
        rng = np.random.default_rng(9)
        pos, vel, path = [], [], []
        for _ in range(60):
            s = world.step(rng.normal(size=(world.n, 2)) * 4.0)
            pos.append(s.positions)
            vel.append(s.velocities)
            path.append(world.substep_positions)
        return np.array(pos), np.array(vel), np.array(path)

    monkeypatch.setattr(world_module, "_direct_period", counted)
    fast = run()
    assert calls[0] == 59  # every period but the first (pymunk checks new bodies then)
    monkeypatch.setattr(world_module, "_pymunk_is_idle", lambda space: False)
    slow = run()
    assert calls[0] == 59
    for a, b in zip(fast, slow, strict=True):
        assert np.array_equal(a, b)
    radii = World(load_map("crowd", n=40, lo=-6.0, hi=6.0, seed=5)).radii
    centres = fast[2].reshape(-1, len(radii), 2)
    gaps = np.hypot(*(centres[:, :, None] - centres[:, None]).transpose(3, 0, 1, 2)) - (
        radii[:, None] + radii[None]
    )
    assert (gaps[:, ~np.eye(len(radii), dtype=bool)] < 0).any()  # the loops met contacts


@pytest.mark.installed
@pytest.mark.slow
def test_bit_identical_across_processes_and_hash_seeds() -> None:
    here = hashlib.sha256()
    for name in ("roundabout", "crowd"):
        spec = load_map(name, seed=7) if name == "crowd" else load_map(name)
        world = World(spec)
        traffic = LaneTraffic.from_map(spec)
        rng = np.random.default_rng(11)
        state = world.state()
        for _ in range(60):
            a = rng.normal(size=(world.n, 2)) * 3.0
            if len(traffic.indices):
                a[traffic.indices] = traffic.accelerations(state.positions, state.velocities)
            state = world.step(a)
            here.update(state.positions.tobytes())
            here.update(state.velocities.tobytes())
    assert _run_digest("12345") == here.hexdigest()


# ---------------------------------------------------------------- every shipped map


@pytest.mark.parametrize("name", available_maps())
def test_shipped_map_runs_200_steps(name: str) -> None:
    spec = load_map(name)
    world = World(spec)
    traffic = LaneTraffic.from_map(spec)
    state = world.state()
    stats = EpisodeStats(
        world.radii,
        world.kinds,
        world.names,
        world.wall_segments(),
        world.dt,
        velocities=state.velocities,
    )
    goals = np.array([r.goal for r in spec.robots], float)
    n = len(spec.robots)  # the bodies driven by agents: robots, then people
    for _ in range(200):
        a = np.zeros((world.n, 2))
        a[:n] = goal_seeking(spec, world, state.positions, state.velocities)
        if len(traffic.indices):
            a[traffic.indices] = traffic.accelerations(state.positions, state.velocities)
        new = world.step(a)
        reached = np.zeros(world.n, dtype=bool)
        reached[:n] = np.hypot(*(new.positions[:n] - goals).T) < spec.episode.goal_tolerance
        stats.update(state.time, state.positions, new.positions, new.velocities, a, reached)
        state = new
        assert np.all(np.isfinite(state.positions))
        assert np.all(np.hypot(*state.velocities.T) <= world.v_max * (1 + LIMIT_RTOL))
    summary = stats.summary()
    assert len(summary.robots) == spec.n_robots and summary.steps == 200
    assert state.time == pytest.approx(20.0)
    # scripted lanes never rear-end themselves
    assert not [c for c in summary.contacts if c.kind_a == c.kind_b == "traffic"]
    # robots made progress towards their goals
    starts = np.array([r.start for r in spec.robots], float)
    assert np.mean(np.hypot(*(state.positions[:n] - goals).T)) < np.mean(
        np.hypot(*(starts - goals).T)
    )


@pytest.mark.parametrize("seed", range(20))
def test_plan_period_kernel_matches_the_numpy_model(seed: int) -> None:
    """The fused kernel of World.step gives exactly the numpy helpers' forces and velocities."""
    from reference.world_reference import scale_to_vmax

    from nao_arena.world import _plan_period, clip_accelerations

    rng = np.random.default_rng(seed)
    n, substeps, dt = int(rng.integers(1, 30)), int(rng.integers(1, 12)), 0.1
    a_max, v_max = rng.uniform(0.5, 3.0, n), rng.uniform(0.5, 3.0, n)
    masses = rng.uniform(0.5, 5.0, n)
    a = rng.normal(0.0, 3.0, (n, 2))
    a[rng.random(n) < 0.2] = 0.0  # some zero commands
    v = rng.normal(0.0, 2.0, (n, 2))  # some above v_max
    on_limit = rng.random(n) < 0.2
    v[on_limit] *= (v_max / np.hypot(*v.T))[on_limit, None]  # some exactly at v_max
    rows = rng.permutation(n + 2)[:n].astype(np.intp)  # body order != batch order
    forces = np.full((substeps, n + 2, 2), np.nan)
    v_out = np.empty((n, 2))
    a_out = np.full((n, 2), np.nan)
    finite, over = _plan_period(a, v, a_max, v_max, masses, dt, rows, forces, v_out, a_out)
    v_ref, over_ref = scale_to_vmax(v, v_max)
    a_ref = clip_accelerations(a, a_max)
    w = substep_weights(speed_limit_time(v_ref, a_ref, v_max), dt, substeps)
    assert finite and over == bool(np.any(over_ref))
    np.testing.assert_array_equal(v_out, v_ref)
    assert a_out.tobytes() == a_ref.tobytes()
    np.testing.assert_array_equal(forces[:, rows], w[:, :, None] * (masses[:, None] * a_ref)[None])
    a[int(rng.integers(n))] = np.nan
    assert _plan_period(a, v, a_max, v_max, masses, dt, rows, forces, v_out, a_out)[0] is False


@pytest.mark.parametrize("seed", range(20))
def test_applied_plans_are_the_clipped_commands_bit_for_bit(seed: int) -> None:
    """applied_plans: the robots' rows of clip_accelerations, the same bits (commands
    from zero to far beyond a_max, subnormal ones), NaN for every other body."""
    from nao_arena.world import applied_plans, clip_accelerations

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    commanded = rng.normal(0.0, 3.0, (n, 2)) * rng.choice([0.0, 1e-310, 1.0, 1e6], (n, 1))
    rows = rng.permutation(n)[: int(rng.integers(0, n + 1))].astype(np.int64)
    a_max = rng.uniform(0.5, 3.0, len(rows))
    got = applied_plans(commanded, rows, a_max, n)
    want = np.full((n, 2), np.nan)
    if len(rows):
        want[rows] = clip_accelerations(commanded[rows], a_max)
    assert got.tobytes() == want.tobytes()


LEAK_SCRIPT = textwrap.dedent(
    """
    import gc, os, sys
    import numpy as np
    from nao_arena.maps import load_map
    from nao_arena.world import World

    def resident_mib():
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

    spec = load_map("crossing")
    world = World(spec)
    still = np.zeros((world.n, 2))

    def churn(times):
        for _ in range(times):
            world.reset()
            world.step(still)
        for _ in range(times // 3):
            World(spec)
        gc.collect()

    churn(3000)
    before = resident_mib()
    churn(3000)
    sys.stdout.write(repr(resident_mib() - before))
    """
)


@pytest.mark.installed
@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc (Linux)")
def test_resets_do_not_leak_memory() -> None:
    """3000 resets and steps of one world, and 1000 worlds built, grow the resident memory
    by less than 2 MiB (pymunk.batch buffers never free their C arrays: 3.7 MiB per 1000
    resets and 2.4 MiB per 1000 worlds when each made new ones, 13 MiB here).

    It runs in a child process, apart from the suite's own heap (1.5 GiB by its end, where
    the allocator's noise alone reached 2.8 MiB), after a first churn of the same size that
    settles the allocator's high-water mark (a smaller one left a one-off 2.1 MiB rise)."""
    res = subprocess.run(
        [sys.executable, "-c", LEAK_SCRIPT],
        capture_output=True,
        text=True,
        check=True,
        cwd=os.path.dirname(os.path.abspath(__file__)),
    )
    assert float(res.stdout) < 2.0
