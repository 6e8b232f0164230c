"""The arena's control period in one compiled call (nao_arena.period) against the world's
step and the statistics' update one by one: the same bits, the same events, the same
summaries; where it does not apply, nothing is done and the step takes the other way."""

from __future__ import annotations

import copy
import dataclasses
import pickle
import subprocess
import sys

import numpy as np
import pytest
from bitwise import same  # tests/bitwise.py

import nao_arena.period as period_module
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.kernels import parse_type, type_name
from nao_arena.maps import load_map
from nao_arena.period import run_period

# goal seeking without avoidance: robots that touch each other and the walls
SCENES = [
    ("crowd", {"n": 24, "lo": -4.0, "hi": 4.0, "seed": 3}, "goal"),
    ("doorway", {}, "goal"),
    ("dense_swap_perturbed", {"n": 10, "lo": -20, "hi": 20}, "nao"),
]


def _same_summary(a: Arena, b: Arena) -> bool:
    """The two episodes' summaries equal to the bit (NaN where the other has NaN)."""
    return same(dataclasses.asdict(a.summary()), dataclasses.asdict(b.summary()))


def count_compiled_periods(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """From now on, calls[0] counts the compiled periods (:func:`control_period`)."""
    compiled = period_module.control_period
    calls = [0]

    def counted(*args: object) -> object:
        calls[0] += 1
        return compiled(*args)

    monkeypatch.setattr(period_module, "control_period", counted)
    return calls


def _episode(name: str, params: dict, agent: str, steps: int) -> tuple[list, Arena]:
    """Each step's (time, positions, velocities, commanded, contacts) and the arena."""
    arena = Arena(load_map(name, **params), ArenaOptions(agent=agent))
    arena.reset(seed=4)
    out = []
    for _ in range(steps):
        r = arena.step()
        out.append((r.time, r.state.positions, r.state.velocities, r.commanded, r.contacts))
        if arena.done:
            break
    return out, arena


@pytest.mark.parametrize(("name", "params", "agent"), SCENES)
def test_the_compiled_period_is_the_step_and_the_update_bit_for_bit(
    name: str, params: dict, agent: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_compiled_periods(monkeypatch)
    fast, fast_arena = _episode(name, params, agent, 150)
    # every period ran compiled but the first (pymunk checks its new bodies then)
    assert calls[0] == len(fast) - 1
    import nao_arena.arena as arena_module

    monkeypatch.setattr(arena_module, "run_period", lambda *args: None)
    slow, slow_arena = _episode(name, params, agent, 150)
    assert calls[0] == len(fast) - 1  # the other way: World.step and EpisodeStats.update
    assert len(fast) == len(slow)
    for a, b in zip(fast, slow, strict=True):
        assert a[0] == b[0]
        for x, y in zip(a[1:4], b[1:4], strict=True):
            assert np.array_equal(x, y)
        assert same([dataclasses.asdict(e) for e in a[4]], [dataclasses.asdict(e) for e in b[4]])
    assert _same_summary(fast_arena, slow_arena)
    assert np.array_equal(fast_arena.world.commands, slow_arena.world.commands)
    assert np.array_equal(fast_arena.world.substep_positions, slow_arena.world.substep_positions)
    assert not fast_arena.world.substep_positions.flags.writeable
    assert not fast_arena.world.applied_accelerations.flags.writeable
    if agent == "goal":
        assert sum(len(step[4]) for step in fast) > 0  # the scene has contacts to count


def test_where_it_does_not_apply_nothing_is_done(monkeypatch: pytest.MonkeyPatch) -> None:
    arena = Arena(load_map("crowd", n=6, lo=-4.0, hi=4.0, seed=1), ArenaOptions(agent="goal"))
    arena.reset(seed=0)
    arena.step()
    assert arena.stats is not None
    commanded = np.zeros((arena.world.n, 2))
    time, steps = arena.world.time, arena.stats.steps
    assert run_period(arena.world, arena.stats, None, commanded) is None
    import nao_arena.world as world_module

    monkeypatch.setattr(world_module, "_pymunk_is_idle", lambda space: False)
    assert arena.world.direct_period() is None
    assert run_period(arena.world, arena.stats, arena._period_inputs, commanded) is None
    assert (arena.world.time, arena.stats.steps) == (time, steps)
    arena.step()  # through pymunk's step
    assert arena.world.time > time and arena.stats.steps == steps + 1


def test_a_non_finite_command_is_refused_and_changes_nothing() -> None:
    def arena() -> Arena:
        a = Arena(load_map("crowd", n=6, lo=-4.0, hi=4.0, seed=1), ArenaOptions(agent="goal"))
        a.reset(seed=0)
        for _ in range(3):
            a.step()
        return a

    refused, clean = arena(), arena()
    assert refused.stats is not None
    bad = np.zeros((refused.world.n, 2))
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="expected finite accelerations"):
        run_period(refused.world, refused.stats, refused._period_inputs, bad)
    assert refused.world.time == clean.world.time
    assert refused.stats.steps == clean.stats.steps
    for _ in range(20):
        refused.step()
        clean.step()
    assert _same_summary(refused, clean)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copied_arena_steps_on_as_the_original(how: str) -> None:
    original = Arena(load_map("crowd", n=12, lo=-4.0, hi=4.0, seed=2), ArenaOptions(agent="goal"))
    original.reset(seed=1)
    for _ in range(10):
        original.step()
    twin = copy.deepcopy(original) if how == "deepcopy" else pickle.loads(pickle.dumps(original))
    assert twin._period_inputs is not None and original._period_inputs is not None
    assert twin._period_inputs.inputs is not original._period_inputs.inputs
    before = original.state.positions.copy()
    for _ in range(30):
        twin.step()
    assert np.array_equal(original.state.positions, before)  # the copy's space is its own
    for _ in range(30):
        original.step()
    assert _same_summary(twin, original)


def test_the_manifest_names_the_compiled_inputs_type() -> None:
    from numba import typeof

    arena = Arena(load_map("crowd", n=3, lo=-4.0, hi=4.0, seed=1), ArenaOptions(agent="goal"))
    arena.reset(seed=0)
    assert arena._period_inputs is not None
    numba_type = typeof(arena._period_inputs.inputs)
    text = type_name(numba_type)
    assert text.startswith('struct_ref("nao_arena.period:PeriodInputsType", (("chip", ')
    assert parse_type(text) == numba_type


def test_inputs_left_behind_by_a_reset_of_the_world_alone_are_not_used(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A reset of the world alone makes a new chipmunk space (the inputs hold the old
    one's address): the arena's steps then go the other way, and nothing crashes."""
    arena = Arena(load_map("crowd", n=6, lo=-4.0, hi=4.0, seed=1), ArenaOptions(agent="goal"))
    arena.reset(seed=0)
    for _ in range(3):
        arena.step()
    calls = count_compiled_periods(monkeypatch)
    arena.step()
    assert calls[0] == 1
    arena.world.reset()
    for _ in range(5):
        arena.step()
    assert calls[0] == 1 and arena.world.time == pytest.approx(0.5)


def test_warm_up_loads_the_period_kernels_before_any_episode() -> None:
    code = (
        "from nao_arena.arena import Arena\n"
        "from nao_arena.period import control_period\n"
        "from nao_arena.world import _plan_period\n"
        "assert not control_period.signatures and not _plan_period.signatures\n"
        "Arena.warm_up()\n"
        "assert len(control_period.signatures) == 1 and len(_plan_period.signatures) == 1\n"
        "Arena.warm_up()  # once per process\n"
        "assert len(control_period.signatures) == 1\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
