"""benchmarks/people/contact_breakdown.py on a trial it can be checked against by hand: a
robot that stands still, walked into by a recorded person who appeared 0.4 s before the
touch, or by one in the scene for 1.4 s before it."""

from __future__ import annotations

import functools
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "people" / "contact_breakdown.py"

STAND = '''
import numpy as np


class Stand:
    """Stands still, whatever comes."""

    def reset(self, spec, rng):
        pass

    def act(self, obs):
        return -np.asarray(obs.velocity) / 0.1
'''


@functools.cache
def _script():
    """The script as a module (registered, as its dataclass needs)."""
    spec = importlib.util.spec_from_file_location("contact_breakdown", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _map(folder: Path, appears: int, x0: float) -> Path:
    """A robot standing at (0, 0) and a person walking at -1 m/s along y = 0 from x = x0
    m, appearing at frame ``appears`` (10 fps): its disc (0.3 m) meets the robot's (0.3
    m) x0 - 0.6 s after it appears."""
    tracks = folder / f"walk{appears}.txt"
    rows = [(f, 1, x0 - 0.1 * (f - appears), 0.0) for f in range(appears, appears + 31)]
    tracks.write_text("\n".join(f"{f} {i} {x!r} {y!r}" for f, i, x, y in rows) + "\n")
    path = folder / f"walk{appears}.yaml"
    data = {
        "name": f"walk{appears}",
        "bounds": {"min": [-5, -5], "max": [5, 5]},
        "robots": [{"name": "r", "start": [0.0, 0.0], "goal": [0.0, 4.0], "agent": "goal"}],
        "traffic": [
            {
                "type": "recorded",
                "file": tracks.name,
                "format": "xy",
                "fps": 10.0,
                "time_offset": 0.0,
                "radius": 0.3,
            }
        ],
        "episode": {"time_limit": 3.0},
    }
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.slow
def test_the_breakdown_sorts_first_touches(tmp_path: Path) -> None:
    stand = tmp_path / "stand.py"
    stand.write_text(STAND)
    late, early = _map(tmp_path, 5, 1.0), _map(tmp_path, 0, 2.0)
    out = tmp_path / "trial"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "nao_arena.cli",
            "trial",
            "--map",
            f"{late},{early}",
            "--agent",
            f"stand={stand}:Stand",
            "--episodes",
            "1",
            "--workers",
            "1",
            "--log",
            "contacts",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    touches = _script().first_touches(out)
    by_map = {t.map: t for t in touches}
    assert sorted(by_map) == ["walk0", "walk5"]
    for t in touches:
        assert t.agent == "stand" and t.at_rest and not t.caused
    # the contacts begin 0.4 and 1.4 s after the people appear
    assert by_map["walk5"].seen_for == pytest.approx(0.4, abs=0.06)
    assert by_map["walk0"].seen_for == pytest.approx(1.4, abs=0.06)
    pairs = _script().trial_pairs(out)
    assert pairs == [("walk5", "stand"), ("walk0", "stand")]
    assert _script().table(pairs, touches, 1.0).splitlines()[2:] == [
        "| walk5 | stand | 1 | 1 | 0 | 1 (0) |",
        "| walk0 | stand | 1 | 1 | 0 | 0 (0) |",
    ]


def test_the_table_counts_each_map_and_agent() -> None:
    script = _script()
    touch = script.FirstTouch
    touches = [
        touch("m", "nao", at_rest=True, caused=False, seen_for=0.2),
        touch("m", "nao", at_rest=False, caused=True, seen_for=0.5),
        touch("m", "nao", at_rest=False, caused=True, seen_for=3.0),
        touch("m", "orca", at_rest=False, caused=True, seen_for=2.0),
    ]
    pairs = [("m", "orca"), ("m", "nao"), ("m", "goal")]
    lines = script.table(pairs, touches, 1.0).splitlines()
    assert lines[0].endswith("| seen less than 1 s before (robot-caused) |")
    assert lines[2:] == [
        "| m | orca | 1 | 0 | 1 | 0 (0) |",
        "| m | nao | 3 | 1 | 2 | 2 (1) |",
        "| m | goal | 0 | 0 | 0 | 0 (0) |",
    ]


def test_a_folder_without_a_trial_is_a_one_line_error(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(tmp_path)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (
        f"contact_breakdown: error: {tmp_path}: expected a trial folder with collisions.parquet\n"
    )
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(tmp_path), "--seen-within", "nan"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (
        "contact_breakdown: error: --seen-within: expected a positive number of seconds, got nan\n"
    )
