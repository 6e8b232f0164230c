"""benchmarks/robustness.py: its ``deadlocked`` and ``all at goal (s)`` columns against
counts taken here directly from ``Arena(...).run(seed)`` summaries, its ``--json``
output against the table, and its ``--plot`` figures.

The scenes are small (4 robots each) so that the whole file takes a few seconds once the
kernels are compiled: circle_swap_perturbed with 4 robots (every robot of nao arrives)
and two crossing streams of 2 robots with a 32 s time limit (robots that time out, and
episodes in which not every robot arrives)."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import statistics
import sys
import types
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "robustness.py"

SCENES = {  # scene argument -> (map name, its parameters)
    "circle_swap_perturbed:n=4": ("circle_swap_perturbed", {"n": 4}),
    "crossing_streams_perturbed:n=2,time_limit=32.0,perturb=0.3": (
        "crossing_streams_perturbed",
        {"n": 2, "time_limit": 32.0, "perturb": 0.3},
    ),
}
SETTINGS: dict[str, dict[str, Any]] = {  # setting argument -> ArenaOptions keywords
    "perfect": {},
    "position=0.1": {"sensing_noise": {"position": 0.1}},
    "latency=0.1": {"sensing_latency": 0.1},
}
AGENTS = ("goal", "nao")
SEEDS = 3
PNG = b"\x89PNG\r\n\x1a\n"


def load_script() -> types.ModuleType:
    spec = importlib.util.spec_from_file_location("robustness_bench", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while defined
    spec.loader.exec_module(module)
    return module


@dataclass(frozen=True)
class Counted:
    """One episode, counted here (independently of the script's counting)."""

    robots: int
    with_contact: int
    events: int
    succeeded: int
    deadlocked: int
    last_arrival: float | None


def count(scene: str, setting: str, agent: str, seed: int) -> Counted:
    name, params = SCENES[scene]
    spec = load_map(name, **params, seed=seed)  # both maps are seeded
    summary = Arena(spec, ArenaOptions(agent=agent, **SETTINGS[setting])).run(seed)
    robots = summary.robots
    touched = {
        body
        for c in summary.contacts
        for body, kind in ((c.a, c.kind_a), (c.b, c.kind_b))
        if kind == "robot"
    }
    # the per-robot contact counter says the same as the contact events
    assert {r.index for r in robots if r.collisions > 0} == touched
    return Counted(
        robots=len(robots),
        with_contact=len(touched),
        events=sum("robot" in (c.kind_a, c.kind_b) for c in summary.contacts),
        succeeded=sum(r.success for r in robots),
        deadlocked=sum(not r.at_goal_at_end and r.collisions == 0 for r in robots),
        last_arrival=(
            max(r.time_to_goal for r in robots) if all(r.reached_goal for r in robots) else None
        ),
    )


def cells() -> list[tuple[str, str, str]]:
    return [(sc, se, a) for sc in SCENES for se in SETTINGS for a in AGENTS]


@pytest.fixture(scope="module")
def script() -> types.ModuleType:
    return load_script()


@pytest.fixture(scope="module")
def expected() -> dict[tuple[str, str, str], list[Counted]]:
    return {cell: [count(*cell, seed) for seed in range(SEEDS)] for cell in cells()}


@pytest.fixture(scope="module")
def run(script, tmp_path_factory) -> dict[str, Any]:
    """One run of the script's main (markdown table, --json and --plot)."""
    out = tmp_path_factory.mktemp("robustness")
    argv = ["--seeds", str(SEEDS), "--agents", ",".join(AGENTS), "--markdown"]
    argv += ["--scenes", *SCENES, "--settings", *SETTINGS]
    argv += ["--json", str(out / "cells.json"), "--plot", str(out / "figures")]
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        script.main(argv)
    lines = stdout.getvalue().splitlines()
    rows = [[c.strip() for c in line.strip().strip("|").split(" | ")] for line in lines]
    return {"out": out, "header": rows[0], "rule": lines[1], "rows": rows[2:], "stderr": stderr}


def test_table_counts_match_the_episode_summaries(run, expected) -> None:
    header = run["header"]
    assert header == [
        "scene",
        "setting",
        "agent",
        "robot-episodes with a contact",
        "contacts",
        "succeeded",
        "episodes",
        "deadlocked",
        "all at goal (s)",
    ]
    assert run["rule"] == "|" + " --- |" * len(header)
    assert [tuple(r[:3]) for r in run["rows"]] == cells()
    for row in run["rows"]:
        counted = expected[(row[0], row[1], row[2])]
        robots = sum(c.robots for c in counted)
        assert row[3].startswith(f"{sum(c.with_contact for c in counted)}/{robots} [")
        assert row[4] == str(sum(c.events for c in counted))
        assert row[5] == f"{sum(c.succeeded for c in counted)}/{robots}"
        assert row[6] == str(SEEDS)
        assert row[7] == f"{sum(c.deadlocked for c in counted)}/{robots}", row
        times = [c.last_arrival for c in counted if c.last_arrival is not None]
        median = f"{statistics.median(times):.1f}" if times else "-"
        assert row[8] == f"{median} ({len(times)}/{SEEDS})", row
    # the scenes exercise both new columns: robots that time out without a contact next to
    # robots that touch something or arrive, and episodes with and without every robot home
    everything = [c for counted in expected.values() for c in counted]
    assert 0 < sum(c.deadlocked for c in everything) < sum(c.robots for c in everything)
    assert any(0 < c.deadlocked < c.robots for c in everything)
    assert any(c.last_arrival is None for c in everything)
    assert any(c.last_arrival is not None for c in everything)


def test_json_holds_every_seed_and_agrees_with_the_table(run, expected) -> None:
    doc = json.loads((run["out"] / "cells.json").read_text(encoding="utf-8"))
    assert doc["seeds"] == SEEDS
    assert [(c["scene"], c["setting"], c["agent"]) for c in doc["cells"]] == cells()
    for cell, row in zip(doc["cells"], run["rows"], strict=True):
        counted = expected[(cell["scene"], cell["setting"], cell["agent"])]
        assert cell["episodes"] == [
            {
                "seed": seed,
                "robots": c.robots,
                "robots_with_contact": c.with_contact,
                "contact_events": c.events,
                "succeeded": c.succeeded,
                "deadlocked": c.deadlocked,
                "all_at_goal_time": c.last_arrival,
            }
            for seed, c in enumerate(counted)
        ]
        eps = cell["episodes"]
        robots = sum(e["robots"] for e in eps)
        assert row[3].startswith(f"{sum(e['robots_with_contact'] for e in eps)}/{robots} [")
        assert row[4] == str(sum(e["contact_events"] for e in eps))
        assert row[7] == f"{sum(e['deadlocked'] for e in eps)}/{robots}"
        times = [e["all_at_goal_time"] for e in eps if e["all_at_goal_time"] is not None]
        assert row[8].endswith(f"({len(times)}/{len(eps)})")
        if times:
            assert float(row[8].split()[0]) == pytest.approx(statistics.median(times), abs=0.05)
    assert not [p for p in run["out"].iterdir() if p.name.startswith(".")]  # no temporaries


def test_plot_writes_both_figures(run) -> None:
    folder = run["out"] / "figures"
    assert sorted(p.name for p in folder.iterdir()) == [
        "contact_vs_latency.png",
        "contact_vs_noise.png",
    ]
    for path in folder.iterdir():
        data = path.read_bytes()
        assert data.startswith(PNG) and len(data) > 10_000, path
    assert run["stderr"].getvalue() == ""


def test_plot_skips_a_figure_with_one_x_value(script, tmp_path) -> None:
    argv = ["--seeds", "1", "--agents", "goal", "--scenes", "circle_swap_perturbed:n=4"]
    argv += ["--settings", "perfect", "position=0.1", "position=0.05,velocity=0.1"]
    argv += ["--plot", str(tmp_path)]
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        script.main(argv)
    assert [p.name for p in tmp_path.iterdir()] == ["contact_vs_noise.png"]
    assert (tmp_path / "contact_vs_noise.png").read_bytes().startswith(PNG)
    message = stderr.getvalue().splitlines()
    assert len(message) == 1 and "contact_vs_latency.png skipped" in message[0]
    # the plain-text table: the header's columns, padded, in the order of the markdown one
    lines = stdout.getvalue().splitlines()
    assert lines[0].split("  ")[0] == "scene"
    assert lines[0].rstrip().endswith("episodes  deadlocked  all at goal (s)")
    assert len(lines) == 1 + 3


def test_sweep_values_of_the_settings(script) -> None:
    assert script.sweep_value("perfect", "position") == 0.0
    assert script.sweep_value("position=0.05", "position") == 0.05
    assert script.sweep_value("latency=0.2", "latency") == 0.2
    assert script.sweep_value("latency=0.2", "position") is None
    assert script.sweep_value("position=0.05,velocity=0.1", "position") is None
    assert script.sweep_value("comm_latency=0.1", "latency") is None
