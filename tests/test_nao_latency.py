"""Latency compensation of the nao agents (agents/_nao_latency.py): a robot's state driven
through its own commands is the state the world reaches; the command log returns the
commands of the periods asked for; a batch is brought up to now as documented; and NAO
robots acting on old senses keep apart in the world."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena.agents._nao_latency import CommandLog, compensated, drive
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map, map_from_dict
from nao_arena.world import World

DT, SUBSTEPS, A_MAX, V_MAX = 0.1, 10, 2.0, 1.5


def _world(velocities: np.ndarray) -> World:
    n = len(velocities)
    robots = [
        {
            "start": [15.0 * i - 80.0, 0.0],
            "goal": [15.0 * i - 80.0, 0.0],
            "velocity": list(map(float, velocities[i])),
            "radius": 0.5,
            "a_max": A_MAX,
            "v_max": V_MAX,
        }
        for i in range(n)
    ]
    world = World(
        map_from_dict(
            {
                "bounds": {"min": [-100, -100], "max": [100, 100]},
                "robots": robots,
                "physics": {"dt": DT, "substeps": SUBSTEPS},
            }
        )
    )
    world.reset()
    return world


@given(
    st.integers(1, 4),
    st.lists(st.floats(-4.0, 4.0, allow_nan=False), min_size=40, max_size=40),
    st.lists(st.floats(-1.1, 1.1, allow_nan=False), min_size=10, max_size=10),
)
@settings(max_examples=60, deadline=None)
def test_driving_the_commands_reaches_the_worlds_state(periods, commands, velocities):
    """Five robots (some commands beyond a_max, some starts near v_max) driven through
    1 to 4 periods: positions and velocities equal the world's to 1e-12."""
    v0 = np.array(velocities).reshape(5, 2)
    cmds = np.array(commands).reshape(4, 5, 2)[:periods]
    world = _world(v0)
    pos, vel = world.positions.copy(), world.velocities.copy()
    for c in cmds:
        world.step(c)
    p, v = drive(pos, vel, cmds, np.full(5, A_MAX), np.full(5, V_MAX), DT, SUBSTEPS)
    np.testing.assert_allclose(p, world.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v, world.velocities, rtol=0, atol=1e-12)


def test_the_log_gives_each_period_its_command():
    log = CommandLog(keep=3)
    for k in range(5):
        log.add(0.1 * k, np.array([k, -k], dtype=float))
    # kept: the periods starting at 0.2, 0.3, 0.4 s
    got = log.since(0.2, 3, 0.1)
    np.testing.assert_array_equal(got, [[2, -2], [3, -3], [4, -4]])
    # asked from earlier than the log holds: those periods count as no command
    np.testing.assert_array_equal(log.since(0.0, 3, 0.1), [[0, 0], [0, 0], [2, -2]])


@pytest.mark.parametrize(("n", "latency"), [(6, 0.1), (6, 0.2), (12, 0.1)])
def test_nao_robots_acting_on_old_senses_do_not_touch(n, latency):
    """With a sensing latency the robots' stopping plans start from where they are now
    (their own commands driven forward): no contact on the perturbed swap, where the
    uncompensated robots touched (6 robots, 0.1 s: a contact in the first seed)."""
    for seed in range(3):
        spec = load_map("circle_swap_perturbed", n=n, seed=seed)
        summary = Arena(spec, ArenaOptions(agent="nao", sensing_latency=latency)).run(seed)
        assert summary.contacts == [], (seed, summary.contacts[:1])
        assert all(r.success for r in summary.robots)


def test_a_batch_brought_up_to_now():
    """The group's rows are driven through their logged commands; the other rows move on
    at their sensed velocity; known paths are read ``age`` s on; time is now."""
    spec = load_map("roundabout")
    arena = Arena(spec, ArenaOptions(agent="goal", sensing_latency=0.3))
    arena.reset(0)
    for _ in range(5):
        arena.step()
    batch = arena._as_sensed(arena.sensing())  # 3 periods old
    assert batch.age == pytest.approx(0.3) and batch.latency == pytest.approx(0.3)
    rows = np.arange(len(arena.robot_ids), dtype=np.int64)
    logs = []
    commands = np.random.default_rng(1).uniform(-2, 2, (3, len(rows), 2))
    for i in rows:
        log = CommandLog(keep=5)
        for k in range(3):
            log.add(batch.time + k * batch.dt, commands[k, i])
        logs.append(log)
    now = compensated(batch, rows, logs)
    own = batch.bodies[rows]
    p, v = drive(
        batch.positions[own],
        batch.velocities[own],
        commands,
        batch.a_max[own],
        batch.v_max[own],
        batch.dt,
        batch.substeps,
    )
    np.testing.assert_array_equal(now.positions[own], p)
    np.testing.assert_array_equal(now.velocities[own], v)
    others = np.setdiff1d(np.arange(len(batch.positions)), own)
    np.testing.assert_allclose(
        now.positions[others], batch.positions[others] + 0.3 * batch.velocities[others]
    )
    assert now.time == pytest.approx(batch.time + 0.3) and now.age == 0.0
    traffic = np.flatnonzero(np.isfinite(batch.known_paths[:, 0, 0]))
    assert len(traffic)
    for k in range(2):  # read 0.3 s on, within the horizon: interpolated
        np.testing.assert_allclose(
            now.known_paths[traffic, 0, k],
            [np.interp(0.3, batch.path_times, batch.known_paths[j, :, k]) for j in traffic],
        )
    # no latency, no change
    plain = Arena(spec, ArenaOptions(agent="goal"))
    plain.reset(0)
    fresh = plain.sensing()
    assert compensated(fresh, rows, logs) is fresh


def test_nao_inverts_the_actuation_lag_so_the_world_applies_its_choice(monkeypatch):
    """With an actuation lag the nao robots command a + (choice - a) / f, which the lag
    turns into their choice: each step the world applies what they chose (to the
    rounding of the inversion), though what they command differs from it."""
    import nao_arena.agents.nao as nao_module

    chosen, commanded = [], []
    through_lag = nao_module._through_lag

    def recorded(agents, out, batch):
        chosen.append(np.array(out))
        commanded.append(through_lag(agents, out, batch))
        return commanded[-1]

    monkeypatch.setattr(nao_module, "_through_lag", recorded)
    spec = load_map("circle_swap_perturbed", n=8, seed=1)
    arena = Arena(spec, ArenaOptions(agent="nao", actuation_lag=0.3))
    arena.reset(1)
    ids = arena.robot_ids
    differed = False
    for _ in range(60):
        arena.step()
        np.testing.assert_allclose(
            arena.world.applied_accelerations[ids], chosen[-1], rtol=0, atol=1e-12
        )
        differed |= not np.allclose(commanded[-1], chosen[-1], atol=1e-6)
    assert differed  # the robots commanded something else than the world applied
