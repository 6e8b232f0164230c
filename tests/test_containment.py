"""Agents cannot corrupt, crash or hang the arena: read-only observations, published plans
as the world applies them, any exception contained (but KeyboardInterrupt and the
episode's wall-clock budget), and the budget itself (:mod:`nao_arena.watchdog`)."""

from __future__ import annotations

import dataclasses
import json
import signal
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from nao_arena.agent import AgentError
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.cli import main
from nao_arena.maps import load_map
from nao_arena.sensing import LastArrayMemo, read_only
from nao_arena.trials import EpisodeTask, TrialConfig, compute_episode
from nao_arena.watchdog import EpisodeTimeout, budget_available, wall_clock_budget

needs_alarm = pytest.mark.skipif(not budget_available(), reason="no SIGALRM on this platform")


def plugin(tmp_path: Path, name: str, body: str) -> str:
    """Write a plug-in file ``name``.py with ``body`` (after ``import numpy as np``); its ref."""
    path = tmp_path / f"{name}.py"
    path.write_text("import numpy as np\n\n" + textwrap.dedent(body))
    return f"{path}"


def swap(n: int = 4, **params) -> object:
    return load_map("circle_swap", n=n, **params)


# --------------------------------------------------------------------------- read-only senses


def _reaches_writable_memory(array: np.ndarray) -> bool:
    """Whether ``array``, or anything along its ``.base`` chain, can be made writable."""
    node: object = array
    while node is not None:
        if isinstance(node, np.ndarray):
            try:
                node.setflags(write=True)
            except ValueError:
                node = node.base
                continue
            return True
        if isinstance(node, memoryview):
            return not node.readonly
        return not isinstance(node, bytes)
    return False


def test_observations_and_batch_are_read_only():
    arena = Arena(swap(), ArenaOptions(agent="goal"))
    arena.reset(0)
    batch = arena.sensing()
    for name in (
        "positions",
        "velocities",
        "accelerations",
        "radii",
        "a_max",
        "v_max",
        "kinds",
        "plans",
        "path_times",
        "bodies",
        "goals",
        "walls",
        "wall_radius",
        "nb_start",
        "nb_index",
    ):
        array = getattr(batch, name)
        assert not array.flags.writeable, name
        assert not _reaches_writable_memory(array), name
    assert isinstance(batch.routes, tuple)
    # a batch made from writable arrays and a list of routes holds frozen copies of them
    route, goals = np.zeros((3, 2)), np.zeros((4, 2))
    other = dataclasses.replace(batch, goals=goals, routes=[route, None, None, None])
    assert not other.goals.flags.writeable and not np.shares_memory(other.goals, goals)
    assert isinstance(other.routes, tuple) and not other.routes[0].flags.writeable
    assert not _reaches_writable_memory(other.routes[0])
    assert goals.flags.writeable and route.flags.writeable
    obs = batch.observation(0)
    for arr in (
        obs.position,
        obs.velocity,
        obs.acceleration,
        obs.goal,
        obs.walls,
        obs.wall_radius,
        obs.neighbours.ids,
        obs.neighbours.path_times,
    ):
        assert not arr.flags.writeable
        assert not _reaches_writable_memory(arr)
    everyone = batch.everyone()
    assert not everyone.positions.flags.writeable and not everyone.plans.flags.writeable
    # the arena's own state is not frozen, and the senses share no memory with it
    assert arena.state.positions.flags.writeable
    for mine, senses in (
        (arena.state.positions, batch.positions),
        (arena.world.radii, batch.radii),
        (arena.world.a_max, batch.a_max),
        (arena.world.v_max, batch.v_max),
    ):
        assert not np.shares_memory(senses, mine)
    # nor can an attribute of the batch be replaced
    with pytest.raises(dataclasses.FrozenInstanceError):
        batch.goals = np.zeros((4, 2))  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        obs.goal = np.zeros(2)  # type: ignore[misc]


def test_what_agents_derive_from_kinds_is_remembered_for_frozen_arrays_only():
    calls: list[int] = []
    memo = LastArrayMemo(lambda kinds: calls.append(1) or tuple(kinds))
    frozen = read_only(np.array(["robot", "traffic"]))
    assert memo(frozen) == ("robot", "traffic") and memo(frozen) == ("robot", "traffic")
    assert len(calls) == 1
    writable = np.array(["robot", "robot"], dtype="<U7")
    assert memo(writable) == ("robot", "robot")
    writable[1] = "traffic"
    assert memo(writable) == ("robot", "traffic") and len(calls) == 3
    # an arena's batches share its kinds array, so its tuple is worked out once
    arena = Arena(swap(), ArenaOptions(agent="goal"))
    arena.reset(0)
    first = arena.sensing().everyone().kinds
    arena.step()
    assert arena.sensing().everyone().kinds is first
    # threads that share a memo get what their own array gives
    other = read_only(np.array(["traffic"]))
    wrong: list[object] = []

    def ask(kinds: np.ndarray, expected: tuple[str, ...]) -> None:
        for _ in range(2000):
            if memo(kinds) != expected:
                wrong.append(kinds)

    threads = [
        threading.Thread(target=ask, args=(frozen, ("robot", "traffic"))),
        threading.Thread(target=ask, args=(other, ("traffic",))),
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not wrong


def test_an_agent_cannot_fake_its_results_through_what_it_senses(tmp_path):
    """The audit's attack: ``obs.goal.setflags(write=True); obs.goal[:] = obs.position``
    made every robot "succeed" at once; walls were overwritten the same way, and the
    limits through ``batch.a_max.base``. Each attempt is now a fault that changes nothing."""
    cheater = plugin(
        tmp_path,
        "cheater",
        """
        class Cheater:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                for array in (obs.goal, obs.walls, obs.position):
                    node = array
                    while node is not None:
                        try:
                            node.setflags(write=True)
                        except (ValueError, AttributeError):
                            pass
                        node = getattr(node, "base", None)
                obs.goal[:] = obs.position
                return np.zeros(2)

        class BatchCheater:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                return np.zeros(2)

            @classmethod
            def act_batch(cls, agents, batch, rows):
                for name in ("goals", "a_max", "v_max", "radii", "walls"):
                    base = getattr(batch, name).base
                    try:
                        base.setflags(write=True)
                        base[...] = 0.0
                    except (ValueError, AttributeError, TypeError):
                        pass
                batch.goals = batch.positions[batch.bodies]
                return np.zeros((len(rows), 2))
        """,
    )
    for cls in ("Cheater", "BatchCheater"):
        arena = Arena(load_map("crossing"), ArenaOptions(agent=f"{cheater}:{cls}"))
        goals, a_max = arena.goals.copy(), arena.world.a_max.copy()
        summary = arena.run(0, max_steps=20)
        assert not any(r.success for r in summary.robots), cls
        assert len(summary.faults) == 20 * len(arena.robots), cls
        np.testing.assert_array_equal(arena.goals, goals)
        np.testing.assert_array_equal(arena.world.a_max, a_max)


def test_in_place_write_is_a_fault_and_changes_nothing(tmp_path):
    """`rel = obs.position; rel -= obs.goal` used to move the robots' goals and positions
    (thousands of contacts, kilometres of path, no fault); now every call is a fault and
    the episode is exactly that of an agent that does nothing."""
    writer = (
        plugin(
            tmp_path,
            "writer",
            """
        class Writer:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                rel = obs.position
                rel -= obs.goal
                return -rel
        """,
        )
        + ":Writer"
    )
    idle = (
        plugin(
            tmp_path,
            "idle",
            """
        class Idle:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                return np.zeros(2)
        """,
        )
        + ":Idle"
    )
    runs = {}
    for ref in (writer, idle):
        arena = Arena(swap(), ArenaOptions(agent=ref))
        goals = arena.goals.copy()
        runs[ref] = (arena.run(0, max_steps=30), arena)
        np.testing.assert_array_equal(arena.goals, goals)
    bad, bad_arena = runs[writer]
    good, good_arena = runs[idle]
    np.testing.assert_array_equal(bad_arena.state.positions, good_arena.state.positions)
    assert len(bad.faults) == 30 * 4 and not good.faults
    assert all("read-only" in f.message for f in bad.faults)
    for b, g in zip(bad.robots, good.robots, strict=True):
        assert b.path_length == g.path_length and b.collisions == g.collisions


def test_batched_agent_cannot_write_the_batch(tmp_path):
    ref = (
        plugin(
            tmp_path,
            "batch_writer",
            """
        class BatchWriter:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                return np.zeros(2)

            @classmethod
            def act_batch(cls, agents, batch, rows):
                batch.positions[:] = 0.0
                return [np.zeros(2) for _ in rows]
        """,
        )
        + ":BatchWriter"
    )
    arena = Arena(swap(), ArenaOptions(agent=ref))
    arena.reset(0)
    start = arena.state.positions.copy()
    res = arena.step()
    assert len(res.faults) == 4 and "read-only" in res.faults[0].message
    np.testing.assert_array_equal(arena.world.previous_positions, start)


# --------------------------------------------------------------------------- shared plans


def test_published_plans_are_what_the_world_applies(tmp_path):
    """A plug-in commanding (1e300, 0) next to NAO robots that predict with shared plans:
    its plan is scaled to a_max like the world's command, and no NAO robot faults."""
    huge = (
        plugin(
            tmp_path,
            "huge",
            """
        class Huge:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                return np.array([1e300, 0.0])
        """,
        )
        + ":Huge"
    )
    spec = swap(4, predictor="shared_plan", agent="nao")
    robots = list(spec.robots)
    robots[0] = robots[0].model_copy(update={"agent": huge})
    arena = Arena(spec.model_copy(update={"robots": robots}))
    arena.reset(1)
    for _ in range(30):
        res = arena.step()
        assert not res.faults, res.faults[:1]
    plans = arena.sensing().plans[arena.robot_ids]
    a_max = arena.world.a_max[arena.robot_ids[0]]
    assert plans[0, 0] == pytest.approx(a_max) and plans[0, 1] == 0.0
    assert np.all(np.hypot(*plans.T) <= arena.world.a_max[arena.robot_ids] * (1 + 1e-12))
    np.testing.assert_array_equal(plans[1:], arena.commanded[arena.robot_ids[1:]])


# --------------------------------------------------------------------------- any exception


EXITS = """
    class Exits:
        def reset(self, spec, rng):
            pass

        def act(self, obs):
            raise SystemExit(3)


    class ExitsBatch(Exits):
        @classmethod
        def act_batch(cls, agents, batch, rows):
            raise SystemExit(3)
    """


@pytest.mark.parametrize("cls", ["Exits", "ExitsBatch"])
def test_system_exit_in_act_is_a_fault(tmp_path, cls):
    ref = plugin(tmp_path, "exits", EXITS) + f":{cls}"
    arena = Arena(swap(2), ArenaOptions(agent=ref))
    summary = arena.run(0, max_steps=3)
    assert len(summary.faults) == 6 and summary.faults[0].message == "SystemExit: 3"
    assert np.all(arena.commanded == 0.0)


@pytest.mark.parametrize("exc", ["KeyboardInterrupt()", "EpisodeTimeout(1.0)"])
@pytest.mark.parametrize("where", ["act", "act_batch", "reset", "__init__"])
def test_interrupt_and_timeout_are_not_contained(tmp_path, where, exc):
    raiser = f"        def {where}(self, *args):\n            raise {exc}\n"
    if where == "act_batch":
        raiser = (
            "        @classmethod\n"
            f"        def act_batch(cls, agents, batch, rows):\n            raise {exc}\n"
        )
    body = (
        "from nao_arena.watchdog import EpisodeTimeout\n\n"
        "class Stops:\n"
        "        def reset(self, spec, rng):\n            pass\n\n"
        "        def act(self, obs):\n            return np.zeros(2)\n\n" + raiser
    )
    ref = plugin(tmp_path, f"stops_{where}", body) + ":Stops"
    arena = Arena(swap(2), ArenaOptions(agent=ref))
    with pytest.raises((KeyboardInterrupt, EpisodeTimeout)) as info:
        arena.run(0, max_steps=3)
    assert type(info.value).__name__ == exc.split("(")[0]


QUITS = """
    class QuitsInInit:
        def __init__(self):
            raise SystemExit(3)

        def reset(self, spec, rng):
            pass

        def act(self, obs):
            return np.zeros(2)


    class QuitsInReset:
        def reset(self, spec, rng):
            raise SystemExit(3)

        def act(self, obs):
            return np.zeros(2)
    """


@pytest.mark.parametrize("where", ["__init__", "reset"])
def test_system_exit_when_making_an_agent_fails_the_episode(tmp_path, where, capsys):
    cls = "QuitsInInit" if where == "__init__" else "QuitsInReset"
    ref = plugin(tmp_path, "quits", QUITS) + f":{cls}"
    stage = "constructor" if where == "__init__" else "reset"
    with pytest.raises(AgentError, match=f"its {stage} raised SystemExit: 3"):
        Arena(swap(2), ArenaOptions(agent=ref)).reset(0)
    task = EpisodeTask(
        map="circle_swap",
        agent=ref,
        episode=0,
        seed=0,
        overrides={"n": 2},
        time_limit=1.0,
        path=str(tmp_path / "x.json"),
    )
    record = compute_episode(task)
    assert record["result"] is None
    assert record["error"].startswith("AgentError: agent ")
    assert f"its {stage} raised SystemExit: 3" in record["error"]
    # `nao-arena run`: a one-line error, exit 2
    assert main(["run", "circle_swap", "--set", "n=2", "--agent", ref]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nao-arena: error: AgentError:") and "SystemExit: 3" in err
    assert "\n" not in err


def test_keyboard_interrupt_in_reset_stops_a_trial_episode(tmp_path):
    ref = (
        plugin(
            tmp_path,
            "ctrl_c",
            """
        class CtrlC:
            def reset(self, spec, rng):
                raise KeyboardInterrupt

            def act(self, obs):
                return np.zeros(2)
        """,
        )
        + ":CtrlC"
    )
    task = EpisodeTask(
        map="circle_swap",
        agent=ref,
        episode=0,
        seed=0,
        overrides={"n": 2},
        time_limit=1.0,
        path=str(tmp_path / "x.json"),
    )
    with pytest.raises(KeyboardInterrupt):
        compute_episode(task)


# --------------------------------------------------------------------------- wall-clock budget


@needs_alarm
def test_budget_interrupts_and_restores_the_previous_handler_and_timer():
    def outer(signum, frame):
        raise AssertionError("the outer timer fired during the test")

    previous = signal.signal(signal.SIGALRM, outer)
    try:
        signal.setitimer(signal.ITIMER_REAL, 300.0)
        start = time.monotonic()
        with pytest.raises(EpisodeTimeout, match="wall-clock budget of 0.2 s"):
            with wall_clock_budget(0.2) as enforced:
                assert enforced
                while True:
                    pass
        assert signal.getsignal(signal.SIGALRM) is outer
        left, _ = signal.getitimer(signal.ITIMER_REAL)
        assert 0 < left <= 300.0 - (time.monotonic() - start) + 1e-3
        with wall_clock_budget(5.0):
            pass
        assert signal.getsignal(signal.SIGALRM) is outer
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


@needs_alarm
def test_budget_repeats_for_an_agent_that_swallows_it_once():
    caught = 0
    with pytest.raises(EpisodeTimeout):
        with wall_clock_budget(0.1):
            try:
                while True:
                    pass
            except EpisodeTimeout:
                caught += 1
            while True:
                pass
    assert caught == 1


def test_budget_off_thread_and_when_zero_is_a_no_op():
    seen = []

    def body():
        with wall_clock_budget(0.05) as enforced:
            seen.append(enforced)

    worker = threading.Thread(target=body)
    worker.start()
    worker.join()
    assert seen == [False]
    for none in (None, 0, 0.0):
        with wall_clock_budget(none) as enforced:
            assert not enforced
    with pytest.raises(ValueError, match="budget"):
        with wall_clock_budget(-1.0):
            pass


def test_episode_timeout_is_validated():
    with pytest.raises(ValueError, match="episode timeout"):
        TrialConfig(maps=("circle_swap",), agents=("goal",), episode_timeout=-1.0)
    assert TrialConfig(maps=("circle_swap",), agents=("goal",)).episode_timeout == 600.0


LOOPS = """
    class LoopAct:
        def reset(self, spec, rng):
            pass

        def act(self, obs):
            while True:
                pass


    class LoopReset:
        def reset(self, spec, rng):
            while True:
                pass

        def act(self, obs):
            return np.zeros(2)
    """


@needs_alarm
@pytest.mark.parametrize("cls", ["LoopAct", "LoopReset"])
def test_run_stops_a_stuck_agent(tmp_path, capsys, cls):
    ref = plugin(tmp_path, "loops", LOOPS) + f":{cls}"
    code = main(["run", "circle_swap", "--set", "n=2", "--agent", ref, "--episode-timeout", "1"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err == (
        "nao-arena: error: EpisodeTimeout: episode exceeded its wall-clock budget of 1 s"
    )
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


@pytest.mark.installed
@pytest.mark.slow
@needs_alarm
def test_trial_with_two_workers_records_stuck_episodes_and_finishes(tmp_path, capsys):
    file = plugin(tmp_path, "loops", LOOPS)
    agents = [f"{file}:LoopAct", f"{file}:LoopReset", "goal"]
    out = tmp_path / "out"
    code = main(
        [
            "trial",
            "--map",
            "circle_swap",
            "--agent",
            ",".join(agents),
            "--episodes",
            "1",
            "--set",
            "n=2",
            "--time-limit",
            "2",
            "--workers",
            "2",
            "--episode-timeout",
            "2",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    records = [json.loads(p.read_text()) for p in sorted((out / "episodes").glob("*.json"))]
    by_agent = {r["key"]["agent"]: r for r in records}
    assert set(by_agent) == set(agents)
    for ref in agents[:2]:
        assert by_agent[ref]["error"] == (
            "EpisodeTimeout: episode exceeded its wall-clock budget of 2 s"
        )
    assert by_agent["goal"]["error"] is None and by_agent["goal"]["result"] is not None
    assert json.loads((out / "trial.json").read_text())["episode_timeout"] == 2.0
