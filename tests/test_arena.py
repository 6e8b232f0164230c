"""The control loop (nao_arena/arena.py): reset, step, run, done, summary; external
actions; fault containment; the recorder hook; act_batch dispatch; determinism.

(Rejected robot indices and act_batch failures of a whole group are also in
tests/test_fast_path.py; plug-in files acting together in tests/test_agent_loading.py.)
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np
import pytest

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import MapSpec, load_map, map_from_dict

HERE = __name__  # agents of this file are named "<module>:<Class>"


def two_robots(
    time_limit: float = 3.0,
    tolerance: float = 0.3,
    starts: tuple = ((-2.0, 0.0), (2.0, 2.0)),
    goals: tuple = ((2.0, 0.0), (-2.0, 2.0)),
) -> MapSpec:
    """Two robots (a_max 2 m/s^2, v_max 1.5 m/s) in a 10 m box, dt 0.1 s."""
    return map_from_dict(
        {
            "bounds": {"min": [-5, -5], "max": [5, 5]},
            "robots": [
                {"start": list(s), "goal": list(g), "agent": "goal"}
                for s, g in zip(starts, goals, strict=True)
            ],
            "episode": {"time_limit": time_limit, "goal_tolerance": tolerance},
        }
    )


class Const:
    """A per-robot agent: a fixed acceleration (m/s^2); counts its calls."""

    def __init__(self, acc: tuple[float, float] = (0.0, 0.0)) -> None:
        self.acc = np.array(acc, dtype=float)
        self.calls = 0
        self.seen: list[int] = []

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        self.calls = 0

    def act(self, obs: Any) -> np.ndarray:
        self.calls += 1
        self.seen.append(obs.robot_id)
        return self.acc.copy()


class Noisy:
    """Random accelerations from the generator the arena gives at reset."""

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        self.rng = rng

    def act(self, obs: Any) -> np.ndarray:
        return self.rng.normal(0.0, 1.0, 2)


class Raises(Const):
    def act(self, obs: Any) -> np.ndarray:
        self.calls += 1
        raise RuntimeError(f"broken at {obs.time:.1f}")


class BatchA:
    """Acts for all its robots at once: 0.1 m/s^2 along x; ``act`` must not be called."""

    calls: list[list[int]] = []
    value = 0.1

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        pass

    def act(self, obs: Any) -> np.ndarray:
        raise AssertionError("act of a batched agent")

    @classmethod
    def act_batch(cls, agents: list, batch: Any, rows: list[int]) -> list[np.ndarray]:
        assert all(type(a) is cls for a in agents)
        cls.calls.append(list(rows))
        return [np.array([cls.value, 0.0]) for _ in rows]


class BatchB(BatchA):
    """A subclass is a group of its own (dispatch is by exact class)."""

    calls: list[list[int]] = []
    value = 0.2


class ShortBatch(BatchA):
    calls: list[list[int]] = []

    @classmethod
    def act_batch(cls, agents: list, batch: Any, rows: list[int]) -> list[np.ndarray]:
        return [np.zeros(2)]


class Tape:
    """A recorder that keeps what the arena hands it."""

    def __init__(self) -> None:
        self.events: list[tuple] = []

    def begin(self, arena: Arena, seed: int | None) -> None:
        assert arena.stats is not None
        self.events.append(
            ("begin", seed, arena.time, arena.stats.steps, arena.state.positions.copy())
        )

    def step(self, arena: Arena, sensing: Any, result: Any, actions: Any) -> None:
        self.events.append(
            ("step", sensing.time, result, dict(actions), arena.state is result.state)
        )


@pytest.fixture(autouse=True)
def _fresh_class_logs():
    for cls in (BatchA, BatchB, ShortBatch):
        cls.calls = []


def arena_with(agents: list, spec: MapSpec | None = None, seed: int = 0) -> Arena:
    """An arena reset with ``seed`` whose agents are then replaced by ``agents``."""
    arena = Arena(spec or two_robots())
    arena.reset(seed)
    arena.agents = agents
    return arena


def state_hash(states: list) -> str:
    """SHA-256 of positions then velocities (float64 bytes) of each state in turn."""
    h = hashlib.sha256()
    for s in states:
        h.update(np.ascontiguousarray(s.positions, dtype=np.float64).tobytes())
        h.update(np.ascontiguousarray(s.velocities, dtype=np.float64).tobytes())
    return h.hexdigest()


# ------------------------------------------------------------------ reset, step, summary


def test_step_advances_time_and_applies_the_agents_accelerations():
    arena = arena_with([Const((1.0, 0.0)), Const((0.0, -0.5))])
    start = arena.state
    res = arena.step()
    assert res.time == pytest.approx(0.1) and arena.time == res.time
    assert res.state is arena.state and arena.state is not start
    np.testing.assert_array_equal(res.commanded[arena.robot_ids], [[1.0, 0.0], [0.0, -0.5]])
    # constant acceleration from rest, below v_max: v = a dt
    np.testing.assert_allclose(
        res.state.velocities[arena.robot_ids], [[0.1, 0.0], [0.0, -0.05]], atol=1e-9
    )
    assert [a.calls for a in arena.agents] == [1, 1]
    assert [a.seen for a in arena.agents] == [[0], [1]]


def test_traffic_gets_its_lane_followers_accelerations():
    arena = Arena(load_map("roundabout"))
    state = arena.reset(0)
    arena.agents = [Const() for _ in arena.agents]
    expected = arena.traffic.accelerations(state.positions, state.velocities)
    res = arena.step()
    assert len(arena.traffic.indices) > 0
    np.testing.assert_array_equal(res.commanded[arena.traffic.indices], expected)
    np.testing.assert_array_equal(res.commanded[arena.robot_ids], 0.0)


def test_reset_starts_a_fresh_episode():
    arena = Arena(two_robots(), ArenaOptions(agent=f"{HERE}:Noisy"))
    first = arena.reset(3)
    first_agents = list(arena.agents)
    fresh = arena.summary()
    for _ in range(5):
        arena.step()
    assert arena.summary().steps == 5
    again = arena.reset(3)
    assert arena.time == 0.0 and arena.summary().steps == 0
    assert arena.summary().trajectory_hash == fresh.trajectory_hash
    np.testing.assert_array_equal(again.positions, first.positions)
    np.testing.assert_array_equal(again.velocities, 0.0)
    np.testing.assert_array_equal(arena.commanded, 0.0)
    assert all(a is not b for a, b in zip(arena.agents, first_agents, strict=True))


def test_summary_hash_is_the_hash_of_every_state():
    arena = Arena(two_robots(), ArenaOptions(agent=f"{HERE}:Noisy"))
    states = [arena.reset(1)]
    states += [arena.step().state for _ in range(4)]
    summary = arena.summary()
    assert summary.steps == 4 and summary.duration == pytest.approx(0.4)
    assert summary.trajectory_hash == state_hash(states)


def test_run_stops_after_max_steps():
    arena = Arena(two_robots())
    summary = arena.run(seed=0, max_steps=3)
    assert summary.steps == 3 and arena.time == pytest.approx(0.3)
    assert not arena.done


def test_run_stops_at_the_time_limit():
    arena = Arena(two_robots(time_limit=1.0), ArenaOptions(agent=f"{HERE}:Const"))
    summary = arena.run(seed=0)
    assert summary.steps == 10 and arena.done
    assert not arena.reached.any()


def test_run_stops_when_every_robot_is_at_its_goal():
    arena = Arena(two_robots(time_limit=30.0))  # goal-seeking robots, paths do not cross
    summary = arena.run(seed=0)
    assert arena.done and arena.reached.all()
    assert summary.steps < 300 and arena.time < 30.0
    assert all(r.at_goal_at_end for r in summary.robots)


def test_done_needs_every_robot_at_its_goal_at_once():
    """Robot 0 starts on its goal, robot 1 0.5 m from its own; both pushed along x,
    robot 0 leaves its goal before robot 1 reaches its own: not done."""
    spec = two_robots(
        starts=((0.0, 0.0), (2.0, 2.0)), goals=((0.0, 0.1), (2.5, 2.0)), tolerance=0.2
    )
    arena = arena_with([Const(), Const()], spec)
    arena.step()
    assert list(arena.reached) == [True, False] and not arena.done
    push = {0: np.array([2.0, 0.0]), 1: np.array([2.0, 0.0])}
    while not arena.reached[1]:
        arena.step(push)
        assert arena.time < 2.0
    assert not arena.reached[0] and not arena.done
    # both on their goals at the end of a step: done
    spec = two_robots(
        starts=((0.0, 0.0), (2.0, 2.0)), goals=((0.0, 0.1), (2.1, 2.0)), tolerance=0.2
    )
    arena = arena_with([Const(), Const()], spec)
    arena.step()
    assert arena.done and arena.time < spec.episode.time_limit


# ------------------------------------------------------------------ external actions


def test_external_actions_replace_those_robots_agents():
    arena = arena_with([Const((1.0, 0.0)), Const((1.0, 0.0))])
    res = arena.step({1: np.array([-0.3, 0.4])})
    assert [a.calls for a in arena.agents] == [1, 0]
    np.testing.assert_array_equal(res.commanded[arena.robot_ids], [[1.0, 0.0], [-0.3, 0.4]])
    res = arena.step()
    assert [a.calls for a in arena.agents] == [2, 1]  # replaced for that step only


def test_external_actions_leave_batched_rows_out():
    spec = load_map("circle_swap", n=4, radius=3.0, lo=-5.0, hi=5.0)
    arena = arena_with([BatchA(), BatchA(), BatchA(), BatchA()], spec)
    res = arena.step({2: np.array([0.0, 0.7])})
    assert BatchA.calls == [[0, 1, 3]]
    np.testing.assert_array_equal(
        res.commanded[arena.robot_ids], [[0.1, 0.0], [0.1, 0.0], [0.0, 0.7], [0.1, 0.0]]
    )
    arena.step({k: np.zeros(2) for k in range(4)})
    assert BatchA.calls == [[0, 1, 3]]  # an empty group is not called


@pytest.mark.parametrize("k", [2, 5, -1])
def test_an_unknown_robot_index_is_refused_before_anything_happens(k):
    tape = Tape()
    arena = Arena(two_robots())
    arena.recorder = tape
    arena.reset(0)
    arena.agents = [Const(), Const()]
    with pytest.raises(
        ValueError,
        match=rf"actions: robot index {k} is not one of the 2 "
        r"robots \(0 \.\. 1\)",
    ):
        arena.step({0: np.zeros(2), k: np.zeros(2)})
    assert arena.time == 0.0 and arena.summary().steps == 0
    assert [a.calls for a in arena.agents] == [0, 0]
    assert [e[0] for e in tape.events] == ["begin"]


# ------------------------------------------------------------------ faults


def test_a_failing_agent_gets_zero_acceleration_and_keeps_being_asked():
    arena = arena_with([Raises(), Const((0.5, 0.0))])
    for step in range(3):
        res = arena.step()
        assert len(res.faults) == 1
        fault = res.faults[0]
        assert (fault.robot, fault.time) == (0, pytest.approx(0.1 * step))
        assert fault.message == f"RuntimeError: broken at {0.1 * step:.1f}"
        np.testing.assert_array_equal(res.commanded[arena.robot_ids], [[0.0, 0.0], [0.5, 0.0]])
    assert arena.agents[0].calls == 3
    recorded = arena.summary().faults
    assert [(f.robot, f.name) for f in recorded] == [(int(arena.robot_ids[0]), "robot0")] * 3


@pytest.mark.parametrize(
    "result, fragment",
    [
        (np.array([np.nan, 0.0]), "non-finite acceleration"),
        (np.zeros(3), "expected an acceleration of shape (2,), got (3,)"),
        ("up", "ValueError"),
    ],
)
def test_a_bad_result_of_act_is_a_fault(result, fragment):
    class Bad(Const):
        def act(self, obs: Any) -> Any:
            return result

    arena = arena_with([Const((0.5, 0.0)), Bad()])
    res = arena.step()
    assert [f.robot for f in res.faults] == [1]
    assert fragment in res.faults[0].message
    np.testing.assert_array_equal(res.commanded[arena.robot_ids], [[0.5, 0.0], [0.0, 0.0]])


def test_act_batch_with_the_wrong_number_of_results_fails_its_group_only():
    arena = arena_with(
        [ShortBatch(), Const((0.5, 0.0)), ShortBatch()],
        load_map("circle_swap", n=3, radius=3.0, lo=-5.0, hi=5.0),
    )
    res = arena.step()
    assert [f.robot for f in res.faults] == [0, 2]
    assert all(
        f.message == "ValueError: act_batch returned 1 results for 2 agents" for f in res.faults
    )
    np.testing.assert_array_equal(
        res.commanded[arena.robot_ids], [[0.0, 0.0], [0.5, 0.0], [0.0, 0.0]]
    )


# ------------------------------------------------------------------ act_batch dispatch


def test_act_batch_is_called_once_per_class_with_its_rows():
    spec = load_map("circle_swap", n=5, radius=3.0, lo=-5.0, hi=5.0)
    arena = arena_with([BatchA(), BatchB(), Const((0.0, 0.3)), BatchB(), BatchA()], spec)
    for _ in range(2):
        res = arena.step()
        assert not res.faults
    assert BatchA.calls == [[0, 4], [0, 4]] and BatchB.calls == [[1, 3], [1, 3]]
    assert arena.agents[2].calls == 2
    np.testing.assert_array_equal(
        res.commanded[arena.robot_ids], [[0.1, 0.0], [0.2, 0.0], [0.0, 0.3], [0.2, 0.0], [0.1, 0.0]]
    )
    # new agents: the groups are worked out again
    arena.agents = [BatchB(), BatchB(), BatchB(), Const(), BatchA()]
    arena.step()
    assert BatchA.calls[-1] == [4] and BatchB.calls[-1] == [0, 1, 2]


# ------------------------------------------------------------------ recorder


def test_the_recorder_sees_the_reset_and_every_step():
    tape = Tape()
    arena = Arena(two_robots())
    arena.recorder = tape
    start = arena.reset(7)
    arena.agents = [Const((1.0, 0.0)), Const()]
    first = arena.step()
    second = arena.step({1: np.array([0.0, 0.2])})
    assert len(tape.events) == 3
    begin, step1, step2 = tape.events
    assert begin[:4] == ("begin", 7, 0.0, 0)
    np.testing.assert_array_equal(begin[4], start.positions)
    assert step1 == ("step", 0.0, first, {}, True)
    assert step2[0] == "step" and step2[1] == pytest.approx(0.1) and step2[2] is second
    assert list(step2[3]) == [1] and step2[4]
    arena.reset(None)
    assert tape.events[-1][:2] == ("begin", None)


def test_no_recorder_no_calls():
    tape = Tape()
    arena = Arena(two_robots())
    arena.recorder = tape
    arena.reset(0)
    arena.recorder = None
    arena.step()
    assert len(tape.events) == 1


# ------------------------------------------------------------------ determinism


def test_same_seed_same_episode_other_seed_other_episode():
    def episode(seed: int, arena: Arena | None = None) -> tuple[str, list]:
        arena = arena or Arena(two_robots(), ArenaOptions(agent=f"{HERE}:Noisy"))
        summary = arena.run(seed=seed, max_steps=10)
        return summary.trajectory_hash, summary.to_dict()["robots"]

    shared = Arena(two_robots(), ArenaOptions(agent=f"{HERE}:Noisy"))
    assert episode(4) == episode(4) == episode(4, shared)
    episode(5, shared)
    assert episode(4, shared) == episode(4)  # the previous episode leaves nothing behind
    assert episode(5)[0] != episode(4)[0]


def test_agents_get_independent_generators_from_the_seed():
    arena = Arena(two_robots(), ArenaOptions(agent=f"{HERE}:Noisy"))
    arena.reset(11)
    a, b = (agent.rng.random(4) for agent in arena.agents)
    assert not np.array_equal(a, b)
    arena.reset(11)
    np.testing.assert_array_equal(arena.agents[0].rng.random(4), a)


def test_shared_plans_are_the_accelerations_the_world_applied() -> None:
    """The sensed plans are the world's applied accelerations of the robots (handed over
    by the world after a step), NaN for traffic: the bits of applied_plans on the
    commands; commands set from outside (an episode log's row) are clipped the same way."""
    from nao_arena.world import applied_plans

    arena = Arena(load_map("roundabout", seed=1))
    arena.reset(1)
    robots = np.asarray(arena.robot_ids, dtype=np.int64)
    a_max = arena.world.a_max[robots]

    def expected() -> np.ndarray:
        return applied_plans(arena.commanded, robots, a_max, arena.world.n)

    rng = np.random.default_rng(0)
    for step in range(12):
        plans = arena.sensing().plans
        assert plans is not None and plans.tobytes() == expected().tobytes()
        far = {k: rng.normal(size=2) * 50.0 for k in range(0, len(robots), 2)} if step % 2 else {}
        arena.step(far)
    arena.commanded = arena.commanded * 0.5
    plans = arena.sensing().plans
    assert plans is not None and plans.tobytes() == expected().tobytes()


def test_step_robots_is_step_with_the_same_actions_bit_for_bit():
    """``step_robots`` (arrays) and ``step`` (a dict) replace the same robots' agents: the
    same states, commands and contacts, with the other robots' agents acting, and with
    every robot replaced (then no agent acts)."""
    for replaced in ([0, 2], [0, 1, 2, 3]):
        spec = load_map("circle_swap", n=4)
        by_dict, by_arrays = Arena(spec), Arena(spec)
        by_dict.reset(seed=3)
        by_arrays.reset(seed=3)
        rng = np.random.default_rng(0)
        robots = np.array(replaced, dtype=np.intp)
        for _ in range(60):
            acc = rng.uniform(-3.0, 3.0, (len(robots), 2))
            a = by_dict.step(dict(zip(robots.tolist(), acc, strict=True)))
            b = by_arrays.step_robots(robots, acc)
            assert np.array_equal(a.state.positions, b.state.positions)
            assert np.array_equal(a.state.velocities, b.state.velocities)
            assert np.array_equal(a.commanded, b.commanded)
            assert [c.to_dict() for c in a.contacts] == [c.to_dict() for c in b.contacts]
        assert by_dict.summary().trajectory_hash == by_arrays.summary().trajectory_hash


@pytest.mark.parametrize(
    ("robots", "accelerations", "message"),
    [
        ([0, 5], np.zeros((2, 2)), r"robots: expected robot indices 0 \.\. 1, got \[0, 5\]"),
        ([-1], np.zeros((1, 2)), r"robots: expected robot indices 0 \.\. 1, got \[-1\]"),
        ([1, 1], np.zeros((2, 2)), r"robots: expected distinct robot indices, got \[1, 1\]"),
        ([[0, 1]], np.zeros((2, 2)), r"robots: expected a 1-d array of indices, got shape"),
        ([0, 1], np.zeros((2, 3)), r"accelerations: expected shape \(2, 2\), got \(2, 3\)"),
    ],
)
def test_step_robots_refuses_bad_arrays_by_name(robots, accelerations, message):
    arena = Arena(load_map("circle_swap", n=2))
    arena.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        arena.step_robots(np.array(robots), accelerations)
    assert arena.time == 0.0  # nothing stepped
