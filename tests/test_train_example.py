"""examples/train_ppo.py: a short PPO training ends with finite losses and its summary,
behind the shield too; ``--save`` writes a policy that loads; a non-finite loss fails.

These tests need the ``rl`` extra (stable-baselines3, with torch) and are skipped without
it, unless NAO_ARENA_REQUIRE_RL=1 (set by .ci/run, which installs the extra): then a
missing stable-baselines3 fails them.
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "train_ppo.py"


@pytest.fixture(autouse=True)
def need_sb3():
    """Skip without stable_baselines3 (fail if NAO_ARENA_REQUIRE_RL=1)."""
    if os.environ.get("NAO_ARENA_REQUIRE_RL") == "1":
        import stable_baselines3  # noqa: F401
    else:
        pytest.importorskip("stable_baselines3", reason="needs the rl extra")


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )


def final_losses(stdout: str) -> dict[str, float]:
    line = re.search(r"^final losses: (.*)$", stdout, re.M).group(1)
    return {k: float(v) for k, v in (item.split("=") for item in line.split(", "))}


def load_example() -> types.ModuleType:
    spec = importlib.util.spec_from_file_location("train_ppo", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_training_finishes_with_finite_losses(tmp_path):
    proc = run("--timesteps", "2000", "--save", str(tmp_path / "p.zip"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    losses = final_losses(proc.stdout)
    assert set(losses) == {"loss", "policy_gradient_loss", "value_loss", "entropy_loss"}
    assert all(math.isfinite(v) for v in losses.values())
    # one rollout: 256 steps x 2 copies x 20 robots
    assert "crowd_v0: 10240 agent-steps in" in proc.stdout
    assert "target not met" in proc.stdout
    assert re.search(r"agent-episodes; the first \d+: mean return -?\d", proc.stdout) or (
        "no agent-episode finished" in proc.stdout
    )
    from stable_baselines3 import PPO

    policy = PPO.load(tmp_path / "p.zip", device="cpu")
    obs = np.full((3, policy.observation_space.shape[0]), 0.5, dtype=np.float32)
    actions, _ = policy.predict(obs, deterministic=True)
    assert actions.shape == (3, 2)


@pytest.mark.slow
def test_shield_flag_trains_behind_the_shield(tmp_path):
    proc = run("--shield", "--timesteps", "2000", "--env", "crossing_v0", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "crossing_v0 behind the shield: " in proc.stdout
    assert all(math.isfinite(v) for v in final_losses(proc.stdout).values())


def test_a_non_finite_loss_fails_the_run(monkeypatch, capsys):
    example = load_example()

    def diverged(env_id, timesteps, **kwargs):  # a training whose last update made NaN
        model = types.SimpleNamespace(
            logger=types.SimpleNamespace(
                name_to_value={
                    "train/loss": float("nan"),
                    "train/policy_gradient_loss": 0.0,
                    "train/value_loss": float("inf"),
                    "train/entropy_loss": -1.0,
                }
            )
        )
        return example.sb3.Training(model, [], 0, timesteps, 1.0, False)

    monkeypatch.setattr(example.sb3, "train", diverged)
    assert example.main(["--timesteps", "8"]) == 1
    out, err = capsys.readouterr()
    assert "final losses: loss=nan, policy_gradient_loss=0, value_loss=inf" in out
    assert "no agent-episode finished" in out
    assert "non-finite losses: loss, value_loss" in err


def test_summary_reports_both_quarters():
    example = load_example()
    eps = [example.sb3.AgentEpisode(i, float(i), i >= 4, 1 if i < 2 else 0, 10) for i in range(8)]
    text = example.summary(eps)
    assert text.startswith("8 agent-episodes; the first 2: mean return 0.5, reached")
    assert "the first 2: mean return 0.5, reached their goals 0/2, 1.00 contact events" in text
    assert "the last 2: mean return 6.5, reached their goals 2/2, 0.00 contact events" in text
