"""Train one PPO policy shared by every robot of a versioned env (Stable-Baselines3).

    pip install torch==2.13.0 ".[rl]"   # or any torch you have; then:
    python examples/train_ppo.py [--env crowd_v0] [--timesteps 6000000] [--target 0.95]
                                 [--copies 2] [--num-cpus 0] [--seed 0] [--shield]
                                 [--save policy.zip]

``nao_arena.sb3`` does the work: SuperSuit turns the parallel env into a vector env with
one entry per robot, so all robots share the policy and every agent-step is one PPO
timestep; training stops once 95 % of the last 500 agent-episodes reached their goals
(``--target``), or after ``--timesteps`` agent-steps. ``--shield`` trains behind the NAO
safety shield (``nao_arena.shield.NAOShield``), which replaces unsafe actions.

Prints the training's agent-steps, wall time and rate, its agent-episodes, their
success and contact events at the start and at the end, and the last update's losses;
exits 1 if a loss is not finite. On crowd_v0 (20 robots) the defaults reach the target
after about half a million agent-steps, a few minutes on one core.
``benchmarks/train_policies.py`` trains and evaluates both envs with and without the
shield and plots the learning curves.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys

from nao_arena import sb3
from nao_arena.envs import available

LOSSES = ("loss", "policy_gradient_loss", "value_loss", "entropy_loss")


def summary(episodes: list[sb3.AgentEpisode]) -> str:
    """Success and contacts of the first and last quarter of ``episodes``."""
    if not episodes:
        return "no agent-episode finished"
    q = max(1, len(episodes) // 4)

    def part(eps: list[sb3.AgentEpisode]) -> str:
        reached = sum(e.reached for e in eps)
        contacts = sum(e.contacts for e in eps)
        ret = sum(e.ret for e in eps) / len(eps)
        return (
            f"mean return {ret:.1f}, reached their goals {reached}/{len(eps)}, "
            f"{contacts / len(eps):.2f} contact events each"
        )

    return (
        f"{len(episodes)} agent-episodes; the first {q}: {part(episodes[:q])}; "
        f"the last {q}: {part(episodes[-q:])}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="crowd_v0", choices=available())
    parser.add_argument("--timesteps", type=float, default=6e6, help="agent-steps at most")
    parser.add_argument("--target", type=float, default=0.95, help="success to stop at")
    parser.add_argument("--copies", type=int, default=2, help="copies of the env")
    parser.add_argument(
        "--num-cpus", type=int, default=0, help="worker processes for the copies (0: here)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--shield", action="store_true", help="train behind the NAO shield")
    parser.add_argument("--save", help="write the trained policy here (SB3 zip)")
    args = parser.parse_args(argv)
    # the first run loads (or, where none are shipped, compiles) the kernels: show it
    # (logger nao_arena.kernels)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    logging.getLogger("nao_arena.kernels").setLevel(logging.INFO)

    run = sb3.train(
        args.env,
        int(args.timesteps),
        shield=args.shield,
        seed=args.seed,
        copies=args.copies,
        num_cpus=args.num_cpus,
        target_success=args.target,
    )
    steps = run.timesteps
    print(
        f"{args.env}{' behind the shield' if args.shield else ''}: {steps} agent-steps in "
        f"{run.seconds:.1f} s ({steps / run.seconds:.0f} agent-steps/s, PPO updates "
        f"included); {run.contacts} contact events; target "
        f"{'met' if run.target_met else 'not met'}"
    )
    print(summary(run.episodes))
    if args.save:
        run.model.save(args.save)
    # the last update's values, recorded after the last log dump
    logged = run.model.logger.name_to_value
    losses = {name: float(logged[f"train/{name}"]) for name in LOSSES}
    print("final losses: " + ", ".join(f"{k}={v:.6g}" for k, v in losses.items()))
    bad = [k for k, v in losses.items() if not math.isfinite(v)]
    if bad:
        print(f"non-finite losses: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
