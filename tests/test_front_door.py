"""The front door: ``nao_arena`` exports the names users need, each imported on first use,
typed for type checkers (an ``if TYPE_CHECKING:`` import of every export)."""

from __future__ import annotations

import ast
import inspect
import json
import subprocess
import sys
from importlib import import_module
from pathlib import Path

import pytest

import nao_arena

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "pettingzoo", "pygame", "pymunk", "gymnasium", "matplotlib", "pydantic")
"""Third-party packages that ``import nao_arena`` must not import."""

API = [
    "AccelLimits",
    "Agent",
    "AgentFault",
    "Arena",
    "ArenaOptions",
    "BatchAgent",
    "Clearance",
    "ContactEvent",
    "EpisodeSummary",
    "MapError",
    "MapSpec",
    "Neighbours",
    "Observation",
    "ObstacleBoundary",
    "PiecewisePath",
    "RobotSpec",
    "Selection",
    "SensingBatch",
    "StepArrays",
    "StepResult",
    "VectorEnv",
    "WorldState",
    "__version__",
    "ao_boundary",
    "ao_boundary_paper",
    "ao_clearance",
    "ao_path",
    "available_maps",
    "bao_boundary",
    "env",
    "grown_with_time",
    "load_map",
    "nao_boundary",
    "nao_clearance",
    "nao_query",
    "parallel_env",
    "path_boundary",
    "path_clearance",
    "repair_acceleration",
    "sampled_path",
    "select_acceleration",
    "vo_clearance",
    "vo_cone",
]


def run_python(code: str) -> object:
    """What ``code`` prints (JSON) in a fresh interpreter, started in the repository."""
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=False
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_the_api_is_the_documented_one():
    assert nao_arena.__all__ == API
    assert sorted(nao_arena._EXPORTS) == [n for n in API if n != "__version__"]


def test_import_is_light():
    """``import nao_arena`` imports no submodule of it (but the standard-library-only
    ``nao_arena._checkout``, which makes a checkout import like an install) and none of the
    heavy dependencies."""
    loaded = run_python(
        "import json, sys, nao_arena\n"
        f"print(json.dumps(sorted(m for m in sys.modules if m.startswith('nao_arena.') "
        f"or m.split('.')[0] in {HEAVY!r})))"
    )
    assert loaded == ["nao_arena._checkout"]


def test_a_name_imports_what_it_needs_only():
    """The control loop does not bring the PettingZoo env (nor pygame) with it."""
    loaded = run_python(
        "import json, sys, nao_arena\n"
        "nao_arena.Arena, nao_arena.load_map, nao_arena.select_acceleration\n"
        "print(json.dumps(sorted({m.split('.')[0] for m in sys.modules} "
        "& {'pettingzoo', 'pygame', 'gymnasium'})))"
    )
    assert loaded == []


@pytest.mark.parametrize("name", [n for n in API if n != "__version__"])
def test_each_export_is_its_definition(name: str):
    module = import_module(nao_arena._EXPORTS[name])
    assert getattr(nao_arena, name) is getattr(module, name)
    assert name in module.__all__


def test_the_type_checking_block_imports_every_export():
    """Type checkers see each export where it is defined (the block mirrors _EXPORTS)."""
    tree = ast.parse((ROOT / "nao_arena" / "__init__.py").read_text(encoding="utf-8"))
    blocks = [
        node
        for node in tree.body
        if isinstance(node, ast.If)
        and isinstance(node.test, ast.Name)
        and node.test.id == "TYPE_CHECKING"
    ]
    assert len(blocks) == 1
    seen = {
        alias.name: node.module
        for node in ast.walk(blocks[0])
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert seen == nao_arena._EXPORTS


def test_every_public_geometry_function_is_exported():
    geometry = import_module("nao_arena.geometry")
    functions = {n for n in geometry.__all__ if inspect.isfunction(getattr(geometry, n))}
    missing = functions - set(nao_arena.__all__)
    assert not missing, f"add to nao_arena's exports: {sorted(missing)}"


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="module 'nao_arena' has no attribute 'Arenaa'"):
        nao_arena.Arenaa  # noqa: B018
    assert not hasattr(nao_arena, "TYPE_CHECKING")


def test_dir_lists_the_exports_not_the_submodules():
    import nao_arena.arena  # noqa: F401 - a submodule becomes an attribute of the package

    public = [n for n in dir(nao_arena) if not n.startswith("_")]
    assert public == sorted(n for n in API if not n.startswith("_"))
    assert "__version__" in dir(nao_arena)


def test_the_front_door_runs_an_episode():
    from nao_arena import Arena, ArenaOptions, available_maps, load_map

    assert "circle_swap" in available_maps()
    arena = Arena(load_map("circle_swap", n=2), ArenaOptions(agent="goal"))
    summary = arena.run(seed=0, max_steps=3)
    assert isinstance(arena.agents[0], nao_arena.Agent)
    assert summary.trajectory_hash


def test_py_typed_marker_is_in_the_package_data():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    assert (ROOT / "nao_arena" / "py.typed").is_file()
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "py.typed" in config["package-data"]["nao_arena"]


def test_the_versioned_envs_are_reachable_after_import_nao_arena():
    out = run_python(
        "import json, nao_arena\n"
        "print(json.dumps(nao_arena.envs.crossing_v0.parallel_env().possible_agents[:2]))"
    )
    assert len(out) == 2
