"""Every shipped map with every built-in agent: a few control steps each, no fault, no
NaN. The lists come from the package (a new map or built-in agent is covered without
editing this file); the meta-tests check that they are the real ones."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from nao_arena.agent import BUILTIN_AGENTS
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import available_maps, load_map

ROOT = Path(__file__).resolve().parents[1]
MAPS = available_maps()
AGENTS = sorted(BUILTIN_AGENTS)
STEPS = 3


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("map_name", MAPS)
def test_map_with_agent_runs(map_name: str, agent: str) -> None:
    arena = Arena(load_map(map_name), ArenaOptions(agent=agent))
    arena.reset(0)
    for _ in range(STEPS):
        result = arena.step()
        assert not result.faults, f"{map_name} with {agent}: {result.faults[0]}"
        assert np.all(np.isfinite(result.commanded))
        assert np.all(np.isfinite(result.state.positions))
        assert np.all(np.isfinite(result.state.velocities))
    summary = arena.summary()
    assert summary.steps == STEPS and not summary.faults
    # --agent drives the robots; the people keep their own agents
    for robot, a in zip(arena.robots, arena.agents, strict=True):
        expected = agent if robot.kind == "robot" else robot.agent
        assert type(a).__name__ == BUILTIN_AGENTS[expected].split(":")[1]


def test_the_matrix_is_every_shipped_map_and_every_built_in_agent() -> None:
    """The maps are the YAML files of maps/ (shipped as nao_arena.maps_data); the agents
    are every public ``*Agent`` class in agents/; the test above iterates both."""
    assert MAPS == sorted(p.stem for p in (ROOT / "maps").glob("*.yaml")) and MAPS
    defined = set()
    for file in sorted((ROOT / "agents").glob("*.py")):
        if file.name.startswith("_"):
            continue
        for node in ast.parse(file.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ClassDef) and node.name.endswith("Agent"):
                defined.add(f"nao_arena.agents.{file.stem}:{node.name}")
    assert defined == set(BUILTIN_AGENTS.values())
    marks = {
        m.args[0]: m.args[1] for m in test_map_with_agent_runs.pytestmark if m.name == "parametrize"
    }
    assert marks == {"map_name": MAPS, "agent": AGENTS}
