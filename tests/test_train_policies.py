"""benchmarks/train_policies.py, a short smoke run: both policies of an env are trained
and evaluated, the JSON, the table and the curves are written, and the table's figures
are the JSON's; bad arguments give one line and exit status 2.

Needs the ``rl`` extra (skipped without it unless NAO_ARENA_REQUIRE_RL=1).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "train_policies.py"

if os.environ.get("NAO_ARENA_REQUIRE_RL") != "1":
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=900,
    )


@pytest.mark.slow
def test_smoke_run_writes_consistent_results(tmp_path):
    out = tmp_path / "out"
    proc = run(
        "--envs", "crossing_v0", "--timesteps", "9000", "--window", "5", "--curve-window", "4",
        "--eval-episodes", "1", "--jobs", "2", "--out", str(out), cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    results = json.loads((out / "training.json").read_text())
    assert [(r["env"], r["trained_with_shield"]) for r in results] == [
        ("crossing_v0", False),
        ("crossing_v0", True),
    ]
    assert (out / "curves_crossing_v0.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from stable_baselines3 import PPO

    for r in results:
        assert r["deterministic"] is False
        policy = PPO.load(out / r["policy"], device="cpu")
        assert policy.observation_space.shape[0] > 4
    table = (out / "training.md").read_text()
    assert table in proc.stdout
    rows = [line for line in table.splitlines() if line.startswith("| crossing_v0")]
    assert len(rows) == 2
    for r, row in zip(results, rows, strict=True):
        t = r["training"]
        # two rollouts of 256 steps x 2 copies x 12 robots
        assert t["timesteps"] == 12288 and not t["target_met"]
        off, on = r["evaluation"]["without_shield"], r["evaluation"]["with_shield"]
        assert off["agent_episodes"] == on["agent_episodes"] == 12
        assert off["interventions"] == 0 and 0 <= on["interventions"] <= on["steps"]
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[2] == str(t["timesteps"])
        assert cells[4].startswith(f"{t['contacts']} (")
        assert cells[6].endswith(f"({off['reached']}/12)")
        assert cells[7] == f"{off['contacts'] / 12:.3f}"
        assert cells[9].endswith(f"({on['reached']}/12)")
        assert cells[11] == f"{on['infeasible_contacts']} of {on['contacts']}"
        episodes = r["episodes"]
        # a 40 s episode (400 steps) of 12 robots in each copy
        assert len(episodes) == t["agent_episodes"] == 24
        assert r["curve"]["window"] == 4 and len(r["curve"]["success"]) == 6
        assert r["curve"]["success"][0] == sum(e[2] for e in episodes[:4]) / 4
        assert t["contacts"] >= sum(e[3] for e in episodes)
    # the shielded training's contacts: fewer than without (none in this run)
    assert results[1]["training"]["contacts"] < results[0]["training"]["contacts"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--envs", "nosuch_v0"), "--envs: unknown env nosuch_v0"),
        (("--target", "1.5"), "--target in (0, 1]"),
        (("--curve-window", "0"), "--curve-window and --eval-episodes >= 1 expected"),
    ],
)
def test_bad_arguments_give_one_line_and_status_2(tmp_path, args, message):
    proc = run(*args, "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert message in proc.stderr
    assert not (tmp_path / "out").exists()
