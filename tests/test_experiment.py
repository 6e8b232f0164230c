"""Experiments as files (``nao-arena trial --config exp.yaml``): the file holds the trial's
options, its relative paths follow it, the command line overrides it, and every bad file
is one line."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from nao_arena.cli import main
from nao_arena.trials.experiment import ExperimentError, read_experiment

IDLE = """
import numpy as np


class Idle:
    def reset(self, spec, rng):
        pass

    def act(self, obs):
        return np.zeros(2)
"""


@pytest.fixture
def study(tmp_path: Path) -> Path:
    """A study folder: an agent file and an experiment naming it relatively."""
    folder = tmp_path / "study"
    (folder / "agents").mkdir(parents=True)
    (folder / "agents" / "idle.py").write_text(IDLE)
    (folder / "exp.yaml").write_text(
        textwrap.dedent("""
        maps: [circle_swap]
        agents: goal, idle=agents/idle.py:Idle
        episodes: 1
        out: results/exp1
        set: {n: 2}
        time_limit: 2
        max_faults: 5
        """)
    )
    return folder


def test_a_study_runs_from_its_file_wherever_it_is_started(study, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # not the study's folder
    assert main(["trial", "--config", str(study / "exp.yaml"), "--quiet"]) == 0
    assert "2 episodes run, 0 already done" in capsys.readouterr().out
    settings = json.loads((study / "results" / "exp1" / "trial.json").read_text())
    assert settings["maps"] == ["circle_swap"] and settings["agents"] == ["goal", "idle"]
    assert settings["agent_refs"] == {"idle": str(study / "agents" / "idle.py") + ":Idle"}
    assert settings["overrides"] == {"n": 2} and settings["time_limit"] == 2.0
    assert settings["max_faults"] == 5 and settings["episodes"] == 1
    # the command line overrides the file: one more episode each, resumed
    assert main(["trial", "--config", str(study / "exp.yaml"), "--episodes", "2", "--quiet"]) == 0
    assert "2 episodes run, 2 already done" in capsys.readouterr().out


def test_the_file_is_read_as_plain_data_with_its_paths(study):
    exp = read_experiment(study / "exp.yaml")
    assert exp.maps == ["circle_swap"]
    assert exp.agents == ["goal", f"idle={study / 'agents' / 'idle.py'}:Idle"]
    assert exp.out == str(study / "results" / "exp1")
    assert exp.episode_timeout == 600.0 and exp.backend == "local" and not exp.csv


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("maps: [a]\nagents: [nao]\n", "out: required field missing"),
        ("maps: [a]\nagents: [nao]\nout: r\nbogus: 1\n", "bogus: unknown key; expected one of"),
        ("maps: [a]\nagents: [nao]\nout: r\nepisodes: 0\n", "episodes: expected a number >= 1"),
        ("maps: [a]\nagents: [nao]\nout: r\nlog: some\n", "log: expected 'all' or 'contacts'"),
        ("maps: []\nagents: [nao]\nout: r\n", "maps: expected at least 1 items"),
        ("maps: [a]\nagents: [nao]\nout: r\ntime_limit: 1e300\n", "time_limit: expected"),
        ("x: &a [1]\ny: *a\n", "without anchors or aliases"),
        ("- 1\n", "expected a mapping of trial options"),
    ],
)
def test_bad_files_are_one_line_errors(tmp_path, capsys, text, expected):
    path = tmp_path / "exp.yaml"
    path.write_text(text)
    with pytest.raises(ExperimentError) as info:
        read_experiment(path)
    assert expected in str(info.value) and "\n" not in str(info.value)
    assert str(info.value).startswith(str(path))
    assert main(["trial", "--config", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nao-arena: error: ") and "\n" not in err


def test_without_a_file_the_grid_options_are_needed(capsys):
    assert main(["trial", "--agent", "nao", "--out", "x"]) == 2
    assert capsys.readouterr().err.strip() == (
        "nao-arena: error: trial: expected --map (or maps: in --config FILE.yaml)"
    )
    assert main(["trial", "--config", "no/such/exp.yaml"]) == 2
    assert "no such experiment file" in capsys.readouterr().err
