"""Train one PPO policy shared by every robot of crowd_v0 (Stable-Baselines3 through SuperSuit).

    pip install torch==2.13.0 ".[rl]"   # or any torch you have; then:
    python examples/train_ppo.py --timesteps 20000 [--envs 2] [--num-cpus 0] [--seed 0]
                                 [--shield]

Four robots with random starts and goals (seeded per episode) in a walled 20 m square.
SuperSuit turns the parallel env into a vector env with one entry per agent, so all agents
share the policy and every agent-step is one PPO timestep. ``keep_finished=True`` keeps
every agent in the env until the episode ends (SuperSuit's vector env needs a fixed set of
agents). The walls bound every observation, so ``normalize_obs_v0`` can scale them to
[0, 1].

``--shield`` wraps the parallel env in ``nao_arena.shield.NAOShield(parallel_env)`` (a NAO
safety shield that corrects unsafe actions) before the rest; without that module it exits
with a message. Prints the wall time, the steps per second and the last update's losses;
exits 1 if a loss is not finite. The mean return of the first and the last quarter of the
agent-episodes shows the learning (random actions hit the walls: about -40; driving
straight to the goal: about +20).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
import warnings
from typing import Any

import supersuit as ss
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import VecEnv, VecMonitor

from nao_arena.envs import crowd_v0

ENV_KWARGS: dict[str, Any] = {
    "n": 4,  # robots (map parameter)
    "time_limit": 15.0,  # s: 150 control steps
    "keep_finished": True,
}
LOSSES = ("loss", "policy_gradient_loss", "value_loss", "entropy_loss")


class Returns(BaseCallback):
    """The return of every finished agent-episode, in order (from VecMonitor's infos)."""

    def __init__(self) -> None:
        super().__init__()
        self.returns: list[float] = []

    def _on_step(self) -> bool:
        self.returns += [float(i["episode"]["r"]) for i in self.locals["infos"] if "episode" in i]
        return True


def load_shield() -> Any:
    """The class ``nao_arena.shield.NAOShield``; exits with a message when it is missing."""
    try:
        from nao_arena.shield import NAOShield
    except ImportError as exc:
        if exc.name != "nao_arena.shield":
            raise  # the shield is there but something it needs is not
        sys.exit(
            f"--shield needs nao_arena.shield.NAOShield (a wrapper of a parallel env: "
            f"NAOShield(parallel_env)), which this installation does not have ({exc})"
        )
    return NAOShield


def make_env(envs: int, seed: int, shield: bool = False, num_cpus: int = 0) -> VecEnv:
    """``envs`` copies of the env, as one SB3 vector env with an entry per agent."""
    par = crowd_v0.parallel_env(**ENV_KWARGS)
    if shield:
        par = load_shield()(par)
    par = ss.normalize_obs_v0(par)
    vec = ss.pettingzoo_env_to_vec_env_v1(par)
    vec = ss.concat_vec_envs_v1(vec, envs, num_cpus=num_cpus, base_class="stable_baselines3")
    # SuperSuit's SB3 wrapper cannot seed (PPO(seed=...) fails): seed the envs below it;
    # later resets draw their seeds from generators seeded here
    vec.venv.reset(seed=seed)
    # (SuperSuit's vector env has no render_mode attribute; rendering is not used here)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="The `render_mode` attribute")
        return VecMonitor(vec)  # episode returns per agent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--timesteps",
        type=int,
        default=20_000,
        help="agent-steps to train (default: %(default)s, about a minute)",
    )
    parser.add_argument("--envs", type=int, default=2, help="copies of the env")
    parser.add_argument(
        "--num-cpus",
        type=int,
        default=0,
        help="worker processes for the copies (0: in this process)",
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--shield", action="store_true", help="wrap the env in nao_arena.shield.NAOShield"
    )
    args = parser.parse_args(argv)
    # the first run compiles the kernels: show its progress (logger nao_arena.kernels)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    logging.getLogger("nao_arena.kernels").setLevel(logging.INFO)

    set_random_seed(args.seed)  # python, numpy, torch
    vec = make_env(args.envs, args.seed, args.shield, args.num_cpus)
    model = PPO(
        "MlpPolicy",
        vec,
        n_steps=128,
        batch_size=256,
        n_epochs=4,
        learning_rate=3e-4,
        gamma=0.99,
        device="cpu",
        verbose=0,
    )
    returns = Returns()
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.timesteps, callback=returns)
    wall = time.perf_counter() - t0
    vec.close()

    agents = len(crowd_v0.parallel_env(**ENV_KWARGS).possible_agents)
    steps = model.num_timesteps
    print(
        f"crowd_v0, {agents} agents x {args.envs} envs: {steps} agent-steps "
        f"({steps // agents} env steps) in {wall:.1f} s: {steps / wall:.0f} agent-steps/s, "
        f"{steps / agents / wall:.0f} env steps/s (PPO updates included)"
    )
    done = returns.returns
    if done:
        q = max(1, len(done) // 4)
        print(
            f"{len(done)} agent-episodes; mean return of the first {q}: "
            f"{sum(done[:q]) / q:.1f}, of the last {q}: {sum(done[-q:]) / q:.1f}"
        )
    # the last update's values, recorded after the last log dump
    logged = model.logger.name_to_value
    losses = {name: float(logged[f"train/{name}"]) for name in LOSSES}
    print("final losses: " + ", ".join(f"{k}={v:.6g}" for k, v in losses.items()))
    bad = [k for k, v in losses.items() if not math.isfinite(v)]
    if bad:
        print(f"non-finite losses: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
