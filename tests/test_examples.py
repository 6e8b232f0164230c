"""What a newcomer reads and runs: the docs' reference parts and the examples/ folder.

Every example runs as a script (as a person would run it, headless), with small
settings passed on its command line so that each takes seconds.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from nao_arena.cli import main
from nao_arena.maps import load_map
from nao_arena.sensing import Neighbours, Observation

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DOCS = ROOT / "docs"
# the pages that hold what the README's sections of these titles held
PAGES = {
    "Agents": "how-to/custom-agent.md",
    "Map files": "how-to/custom-map.md",
    "Examples": "getting-started.md",
}


def _section(title: str) -> str:
    """The docs page that holds the former README section ``## title``."""
    return (DOCS / PAGES[title]).read_text(encoding="utf-8")


def _headless_env() -> dict[str, str]:
    return {
        k: v
        for k, v in os.environ.items()
        if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")
    }


def _script(name: str, *args: str, cwd: Path) -> str:
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        cwd=cwd,
        env=_headless_env(),
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


# --------------------------------------------------------------------------- docs


def test_readme_names_every_field_of_what_an_agent_sees():
    agents = _section("Agents")
    for cls in (Observation, Neighbours):
        assert f"`{cls.__name__}`" in agents
        for f in dataclasses.fields(cls):
            assert f"`{f.name}`" in agents, f"{cls.__name__}.{f.name} is not in the docs"


def test_readme_map_example_loads_and_runs(tmp_path, capsys):
    text = re.search(r"```yaml\n(.*?)```", _section("Map files"), re.S).group(1)
    path = tmp_path / "doorway.yaml"
    path.write_text(text)
    spec = load_map(path)
    assert (spec.name, spec.n_robots, sum(g.count for g in spec.traffic)) == ("doorway", 5, 2)
    assert load_map(path, n=6).n_robots == 7
    assert spec.walls and spec.bounds.walls and spec.sensing.range == 10.0
    assert main(["run", str(path), "--time-limit", "2"]) == 0
    assert "map doorway" in capsys.readouterr().out


def test_readme_points_to_every_example():
    section = _section("Examples")
    examples = sorted(p.name for p in EXAMPLES.iterdir() if p.suffix in (".py", ".yaml"))
    assert examples == [
        "compare_agents.py",
        "custom_agent.py",
        "my_map.yaml",
        "record_gif.py",
        "train_ppo.py",
    ]
    for name in examples:
        assert f"`examples/{name}`" in section


# --------------------------------------------------------------------------- examples


@pytest.mark.installed
@pytest.mark.slow
def test_custom_agent_script(tmp_path):
    out = _script(
        "custom_agent.py", "--map", "crossing", "--set", "n=2", "--time-limit", "3", cwd=tmp_path
    )
    assert out.startswith("crossing: 3.0 s")
    assert [line.split(":")[0].strip() for line in out.splitlines()[1:]] == [
        "east0",
        "east1",
        "north0",
        "north1",
    ]


def test_custom_agent_from_the_command_line_with_a_label(capsys):
    ref = f"polite={EXAMPLES / 'custom_agent.py'}:Polite"
    assert main(["run", "crossing", "--agent", ref, "--set", "n=2", "--time-limit", "3"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith(("east", "north"))]
    assert len(rows) == 4 and {r[1] for r in rows} == {"polite"}


def _map_commands() -> list[list[str]]:
    """The `nao-arena ...` commands in the header of examples/my_map.yaml."""
    text = (EXAMPLES / "my_map.yaml").read_text()
    lines = [
        line.lstrip("# ").split("  #")[0]
        for line in text.splitlines()
        if line.startswith("#   nao-arena ")
    ]
    return [shlex.split(line)[1:] for line in lines]


@pytest.mark.slow
def test_my_map_and_its_commands(tmp_path, capsys):
    spec = load_map(EXAMPLES / "my_map.yaml")
    assert spec.n_robots == 7 and sum(g.count for g in spec.traffic) == 3
    commands = _map_commands()
    assert [c[0] for c in commands] == ["run", "run", "run", "trial"]
    for argv in commands:
        argv = [str(ROOT / a) if a.startswith("examples/") else a for a in argv]
        if "--out" in argv:  # write into the test's folder
            k = argv.index("--out") + 1
            argv[k] = str(tmp_path / Path(argv[k]).name)
        if argv[0] == "trial":
            argv[argv.index("--episodes") + 1] = "1"
            argv.append("--quiet")
        assert main([*argv, "--set", "n=2", "--time-limit", "2"]) == 0, argv
        # run names the file; the trial table the map's name
        shown = "my_map.yaml" if argv[0] == "run" else "pillar_swap"
        assert shown in capsys.readouterr().out
    assert (tmp_path / "pillar.gif").is_file()
    assert json.loads((tmp_path / "pillar" / "summary.json").read_text())[0]["robots"] == 3


@pytest.mark.installed
@pytest.mark.slow
def test_compare_agents_script(tmp_path):
    out_dir = tmp_path / "compare"
    out = _script(
        "compare_agents.py",
        "--map",
        "crossing",
        "--episodes",
        "1",
        "--set",
        "n=2",
        "--time-limit",
        "3",
        "--out",
        str(out_dir),
        cwd=tmp_path,
    )
    rows = [line.split()[:2] for line in out.splitlines() if line.startswith("crossing")]
    assert rows == [["crossing", a] for a in ("nao", "orca", "goal", "polite")]
    summary = json.loads((out_dir / "summary.json").read_text())
    assert [r["agent"] for r in summary] == ["nao", "orca", "goal", "polite"]
    refs = json.loads((out_dir / "trial.json").read_text())["agent_refs"]
    assert refs == {"polite": f"{EXAMPLES / 'custom_agent.py'}:Polite"}
    for name in ("rates.png", "time_to_goal.png", "min_separation.png"):
        assert (out_dir / name).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.installed
@pytest.mark.slow
def test_record_gif_script_headless(tmp_path):
    path = tmp_path / "run.gif"
    out = _script(
        "record_gif.py",
        "--map",
        "circle_swap",
        "--set",
        "n=3",
        "--seconds",
        "1",
        "--fps",
        "5",
        "--out",
        str(path),
        cwd=tmp_path,
    )
    assert out.startswith(f"wrote {path}")
    imageio = pytest.importorskip("imageio.v2")
    frames = imageio.mimread(path)
    assert len(frames) >= 5 and frames[0].ndim == 3
