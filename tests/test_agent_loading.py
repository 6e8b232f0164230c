"""Plug-in agents: loading by file path and module, and containment of faulty agents."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from nao_arena.agent import available_agents, load_agent, safe_act
from nao_arena.arena import Arena, ArenaOptions, make_agent
from nao_arena.maps import load_map
from nao_arena.sensing import Observation
from nao_arena.watchdog import EpisodeTimeout


def obs() -> Observation:
    return Observation(
        time=1.0,
        dt=0.1,
        robot_id=3,
        position=np.zeros(2),
        velocity=np.array([1.0, 0.0]),
        acceleration=np.zeros(2),
        radius=0.5,
        a_max=2.0,
        v_max=2.0,
        goal=np.array([10.0, 0.0]),
    )


def test_builtin_agents_load_and_act():
    for name in ("nao", "ao", "vo", "orca", "goal", "lane"):
        agent = load_agent(name)()
        agent.reset(None, np.random.default_rng(0))
        a = np.asarray(agent.act(obs()))
        assert a.shape == (2,) and np.all(np.isfinite(a)) and np.hypot(*a) <= 2.0 + 1e-9
    assert {"nao", "ao", "vo", "orca", "goal", "lane"} <= set(available_agents())


def test_map_agent_options_reach_only_the_agent_they_are_for():
    spec = load_map("dense_swap_perturbed", n=4)
    assert spec.robots[0].agent_options == {"horizon": 1.5}
    assert spec.robots[0].agent_options_for == "nao"
    horizons = {}
    for name in ("nao", "ao", "orca"):
        arena = Arena(spec, ArenaOptions(agent=name))
        arena.reset(0)
        horizons[name] = arena.agents[0].horizon
    # ao and orca keep their own default horizon (3 s) though they take the option
    assert horizons == {"nao": 1.5, "ao": 3.0, "orca": 3.0}
    everyone = spec.robots[0].model_copy(update={"agent_options_for": None})
    assert make_agent("orca", everyone).horizon == 1.5


def test_a_constructor_with_kwargs_gets_the_predictor_and_the_map_options():
    """A subclass that forwards ``**kwargs`` gets what the map gives the robot: its
    predictor and options (not its base class's defaults)."""
    from nao_arena.agents.nao import NAOAgent

    class Forwarding(NAOAgent):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)

    spec = load_map("dense_swap_perturbed", n=4, predictor="constant_velocity")
    robot = spec.robots[0].model_copy(update={"agent_options_for": None})
    agent = make_agent(Forwarding, robot)
    assert agent.predictor_name == "constant_velocity" and agent.horizon == 1.5
    # the map's options for another agent stay with it
    assert make_agent(Forwarding, spec.robots[0]).horizon == 3.0


def test_agent_from_file_and_module(tmp_path, monkeypatch):
    src = textwrap.dedent(
        """
        import numpy as np

        class Straight:
            def reset(self, spec, rng):
                pass

            def act(self, obs):
                return np.array([0.5, 0.0])
        """
    )
    (tmp_path / "my_agent.py").write_text(src)
    cls = load_agent(f"{tmp_path / 'my_agent.py'}:Straight")
    np.testing.assert_array_equal(cls().act(obs()), [0.5, 0.0])
    monkeypatch.syspath_prepend(str(tmp_path))
    cls = load_agent("my_agent:Straight")
    np.testing.assert_array_equal(cls().act(obs()), [0.5, 0.0])


@pytest.mark.parametrize(
    "ref, fragment",
    [
        ("no_such_agent", "unknown agent"),
        ("missing/file.py:X", "no such file"),
        ("json:NoSuchClass", "defines no"),
    ],
)
def test_bad_agent_references_are_explained(ref, fragment):
    with pytest.raises(ValueError, match=fragment):
        load_agent(ref)


class Raises:
    def act(self, obs):
        raise RuntimeError("boom")


class ReturnsNaN:
    def act(self, obs):
        return np.array([np.nan, 0.0])


class WrongShape:
    def act(self, obs):
        return np.zeros(3)


class Exits:
    def act(self, obs):
        raise SystemExit(3)


@pytest.mark.parametrize(
    "agent, fragment",
    [
        (Raises(), "RuntimeError: boom"),
        (ReturnsNaN(), "non-finite"),
        (WrongShape(), "shape"),
        (Exits(), "SystemExit: 3"),
    ],
)
def test_faulty_agents_are_contained(agent, fragment):
    a, fault = safe_act(agent, obs(), "bad")
    np.testing.assert_array_equal(a, [0.0, 0.0])
    assert fault is not None and fragment in fault.message and fault.robot == 3


class Interrupts:
    def __init__(self, exc: BaseException) -> None:
        self.exc = exc

    def act(self, obs):
        raise self.exc


@pytest.mark.parametrize("exc", [KeyboardInterrupt(), EpisodeTimeout(1.0)])
def test_interrupt_and_timeout_propagate(exc):
    with pytest.raises(type(exc)):
        safe_act(Interrupts(exc), obs(), "stop")


BATCHED = """
import numpy as np
from pathlib import Path

with Path({log!r}).open("a") as fh:
    fh.write("imported\\n")


class Together:
    calls = []

    def reset(self, spec, rng):
        pass

    def act(self, obs):
        return np.zeros(2)

    @classmethod
    def act_batch(cls, agents, batch, rows):
        cls.calls.append(list(rows))
        return [np.zeros(2) for _ in rows]
"""


def test_file_plugin_is_imported_once_and_its_robots_act_together(tmp_path):
    """Two robots of one file plug-in with an act_batch: one call per step for both,
    and the file is executed once across loading, two resets and two arenas."""
    log = tmp_path / "imports.log"
    (tmp_path / "together.py").write_text(BATCHED.format(log=str(log)))
    ref = f"{tmp_path / 'together.py'}:Together"
    cls = load_agent(ref)
    assert load_agent(ref) is cls
    for _ in range(2):
        arena = Arena(load_map("circle_swap", n=2), ArenaOptions(agent=ref))
        for seed in (0, 1):
            arena.reset(seed)
            for _ in range(2):
                arena.step()
            assert all(type(a) is cls for a in arena.agents)
    assert cls.calls == [[0, 1]] * 8
    assert log.read_text() == "imported\n"


def test_plugin_file_that_fails_to_import_is_explained(tmp_path):
    (tmp_path / "quits.py").write_text("raise SystemExit(3)\n")
    with pytest.raises(ValueError, match=r"quits.py:Anything: cannot be loaded \(SystemExit: 3\)"):
        load_agent(f"{tmp_path / 'quits.py'}:Anything")
