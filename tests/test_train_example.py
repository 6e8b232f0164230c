"""examples/train_ppo.py: a short PPO training through SuperSuit ends with finite losses;
``--shield`` wraps the env in ``nao_arena.shield.NAOShield`` or says that it is missing.

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
    proc = run("--timesteps", "2000", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    losses = final_losses(proc.stdout)
    assert set(losses) == {"loss", "policy_gradient_loss", "value_loss", "entropy_loss"}
    assert all(math.isfinite(v) for v in losses.values())
    # 2 envs x 4 agents x 128 steps per rollout: 2048 agent-steps, 512 env steps
    assert "2048 agent-steps (512 env steps)" in proc.stdout
    assert re.search(r"agent-episodes; mean return of the first \d+: -?\d", proc.stdout)


@pytest.mark.slow
def test_shield_flag_uses_the_shield_or_says_it_is_missing(tmp_path):
    proc = run("--shield", "--timesteps", "2000", cwd=tmp_path)
    if importlib.util.find_spec("nao_arena.shield") is None:
        assert proc.returncode == 1
        assert "--shield needs nao_arena.shield.NAOShield" in proc.stderr
        assert "Traceback" not in proc.stderr
    else:
        assert proc.returncode == 0, proc.stderr
        assert all(math.isfinite(v) for v in final_losses(proc.stdout).values())


def test_shield_flag_without_the_module_exits_with_a_message(monkeypatch):
    example = load_example()
    monkeypatch.setitem(sys.modules, "nao_arena.shield", None)  # as if not installed
    with pytest.raises(
        SystemExit,
        match=r"--shield needs nao_arena\.shield\.NAOShield \(a "
        r"wrapper of a parallel env: NAOShield\(parallel_env",
    ):
        example.make_env(1, seed=0, shield=True)


def test_shield_flag_wraps_the_parallel_env(monkeypatch):
    example = load_example()
    wrapped = []

    def shield(par):  # a stand-in that lets everything through
        wrapped.append(par)
        return par

    monkeypatch.setitem(
        sys.modules,
        "nao_arena.shield",
        types.SimpleNamespace(NAOShield=shield, __name__="nao_arena.shield"),
    )
    vec = example.make_env(1, seed=0, shield=True)
    try:
        assert len(wrapped) == 1 and wrapped[0].metadata["name"] == "crowd_v0"
        assert wrapped[0].options.keep_finished
        assert vec.num_envs == len(wrapped[0].possible_agents)
    finally:
        vec.close()


def test_a_non_finite_loss_fails_the_run(monkeypatch, capsys):
    example = load_example()

    class Diverged:  # PPO whose last update produced NaN
        def __init__(self, policy, env, **kwargs):
            self.num_timesteps = 0
            self.logger = types.SimpleNamespace(
                name_to_value={
                    "train/loss": float("nan"),
                    "train/policy_gradient_loss": 0.0,
                    "train/value_loss": float("inf"),
                    "train/entropy_loss": -1.0,
                }
            )

        def learn(self, total_timesteps, callback):
            self.num_timesteps = total_timesteps

    monkeypatch.setattr(example, "PPO", Diverged)
    assert example.main(["--timesteps", "8", "--envs", "1"]) == 1
    out, err = capsys.readouterr()
    assert "final losses: loss=nan, policy_gradient_loss=0, value_loss=inf" in out
    assert "non-finite losses: loss, value_loss" in err
