"""Trained policies with and without the NAO shield: learning curves, success and contacts.

For each env (default ``crowd_v0`` and ``crossing_v0``, their default maps) two PPO
policies are trained (:func:`nao_arena.sb3.train`: one policy shared by every robot),
one on the bare env and one behind the NAO safety shield, each until the success over
its last ``--window`` agent-episodes reaches ``--target`` or ``--timesteps`` agent-steps
have passed. Each trained policy is then evaluated on ``--eval-episodes`` fresh
episodes, seeds 1_000_000 on (training draws its episodes' seeds at random below
2**31), once without the shield and once behind it, its actions drawn from the policy's
distribution as in training (seeded; with ``--deterministic``, the distribution's
mean). The policies are written to
``OUT/policy_<env>_<plain|shield>.zip`` (``stable_baselines3.PPO.load``).

Printed per trained policy, and written (atomically) to ``OUT/training.json`` and
``OUT/training.md``:

- training: agent-steps, wall time, finished agent-episodes, the contact events of all
  agent-steps (per 1000 agent-steps), and the success of the last window;
- evaluation without and with the shield: agent-episodes that reached their goals (of
  all), contact events per agent-episode, and the agent-episodes with a contact (of
  all); with the shield, the share of agent-steps whose action it replaced, and the
  contact events that began while it found no admissible acceleration (status
  ``infeasible``).

A contact event is counted for the robot that started it (``infos["collisions"]``: a
contact between two robots counts for each). ``OUT/curves_<env>.png``: return, success
and contacts per agent-episode over training, per ``--curve-window`` agent-episodes,
both policies. The JSON holds every finished agent-episode of each training
(``episodes``: agent-steps of training when it ended, return, reached, contact events,
steps) and the curves' points. Run (about an hour on a 2-core machine with the defaults):

    python benchmarks/train_policies.py [--envs crowd_v0,crossing_v0] [--timesteps 6000000]
        [--target 0.95] [--window 500] [--curve-window 100] [--eval-episodes 20]
        [--deterministic] [--jobs 2] [--seed 0] [--out training_results]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from multiprocessing import get_context
from pathlib import Path
from typing import Any

EVAL_SEED = 1_000_000
"""The first seed of the evaluation episodes (training draws its seeds below 2**31 from
a generator seeded by ``--seed``; these are fixed and the same for every policy)."""


def run_one(
    env_id: str,
    shield: bool,
    timesteps: int,
    target: float,
    window: int,
    episodes: int,
    deterministic: bool,
    seed: int,
    out: Path,
) -> dict[str, Any]:
    """In a worker process: train one policy, save it into ``out`` and evaluate it; its
    figures as a dict."""
    import torch

    torch.set_num_threads(1)  # one core per training: the jobs run side by side
    from nao_arena.atomic import atomic_write_with
    from nao_arena.sb3 import evaluate, train

    def progress(recorder: Any, steps: int) -> None:
        print(
            f"  {env_id} {'shield' if shield else 'plain '}: {steps} agent-steps, "
            f"{len(recorder.episodes)} agent-episodes, success {recorder.success():.3f}",
            file=sys.stderr,
            flush=True,
        )

    run = train(
        env_id,
        timesteps,
        shield=shield,
        seed=seed,
        target_success=target,
        window=window,
        on_progress=progress,
    )
    out.mkdir(parents=True, exist_ok=True)
    policy = out / f"policy_{env_id}_{'shield' if shield else 'plain'}.zip"
    atomic_write_with(policy, run.model.save, ".zip")
    plain = evaluate(run.model, env_id, episodes, EVAL_SEED, deterministic=deterministic)
    shielded = evaluate(
        run.model, env_id, episodes, EVAL_SEED, shield=True, deterministic=deterministic
    )
    return {
        "env": env_id,
        "trained_with_shield": shield,
        "policy": policy.name,
        "deterministic": deterministic,
        "training": {
            "timesteps": run.timesteps,
            "seconds": run.seconds,
            "agent_episodes": len(run.episodes),
            "contacts": run.contacts,
            "target_met": run.target_met,
            "final_success": sum(e.reached for e in run.episodes[-window:])
            / max(1, len(run.episodes[-window:])),
        },
        "episodes": [[e.timesteps, e.ret, e.reached, e.contacts, e.steps] for e in run.episodes],
        "evaluation": {
            "without_shield": {k: v for k, v in asdict(plain).items() if k != "per_episode"},
            "with_shield": {k: v for k, v in asdict(shielded).items() if k != "per_episode"},
        },
    }


def curve_points(episodes: list[list[Any]], window: int) -> dict[str, Any]:
    """The learning curve (:func:`nao_arena.sb3.learning_curve`) of the JSON's episode
    rows, as a dict of lists."""
    from nao_arena.sb3 import AgentEpisode, learning_curve

    curve = learning_curve([AgentEpisode(*row) for row in episodes], window)
    return {
        "window": curve.window,
        "timesteps": curve.timesteps.tolist(),
        "return": curve.ret.tolist(),
        "success": curve.success.tolist(),
        "contacts": curve.contacts.tolist(),
    }


def pct(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f} % ({part}/{whole})" if whole else "-"


def table(results: list[dict[str, Any]]) -> str:
    """The markdown table of the module docstring."""
    lines = [
        "| env | trained | agent-steps | time | training contacts (per 1000 agent-steps) "
        "| success, last window | success, shield off | contacts per agent-episode, "
        "shield off | with a contact, shield off | success, shield on | contacts per "
        "agent-episode, shield on | contacts while nothing was admissible, shield on "
        "| actions replaced |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
        "| ---: |",
    ]
    for r in results:
        t = r["training"]
        off, on = r["evaluation"]["without_shield"], r["evaluation"]["with_shield"]
        lines.append(
            f"| {r['env']} | {'with shield' if r['trained_with_shield'] else 'without'} "
            f"| {t['timesteps']} | {t['seconds'] / 60:.1f} min "
            f"| {t['contacts']} ({1000 * t['contacts'] / max(1, t['timesteps']):.2f}) "
            f"| {100 * t['final_success']:.1f} % "
            f"| {pct(off['reached'], off['agent_episodes'])} "
            f"| {off['contacts'] / off['agent_episodes']:.3f} "
            f"| {pct(off['with_contact'], off['agent_episodes'])} "
            f"| {pct(on['reached'], on['agent_episodes'])} "
            f"| {on['contacts'] / on['agent_episodes']:.3f} "
            f"| {on['infeasible_contacts']} of {on['contacts']} "
            f"| {pct(on['interventions'], on['steps'])} |"
        )
    return "\n".join(lines) + "\n"


def plot(results: list[dict[str, Any]], env_id: str, path: Path) -> None:
    """``path``: the learning curves of ``env_id``'s two policies (PNG, atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from nao_arena.atomic import atomic_write_with

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), constrained_layout=True)
    for r in results:
        if r["env"] != env_id:
            continue
        c = r["curve"]
        label = "trained with the shield" if r["trained_with_shield"] else "trained without"
        steps = [s / 1e6 for s in c["timesteps"]]
        axes[0].plot(steps, c["return"], label=label)
        axes[1].plot(steps, [100 * s for s in c["success"]], label=label)
        axes[2].plot(steps, c["contacts"], label=label)
    window = results[0]["curve"]["window"]
    titles = ("mean return", "success (%)", "contact events per agent-episode")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_title(title)
        ax.set_xlabel("agent-steps of training (millions)")
        ax.grid(alpha=0.3)
    axes[1].axhline(90, color="grey", lw=0.8, ls="--")
    axes[0].legend()
    fig.suptitle(f"{env_id}: one PPO policy for every robot, per {window} agent-episodes")
    atomic_write_with(path, lambda tmp: fig.savefig(tmp, dpi=90, format="png"), ".png")
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", default="crowd_v0,crossing_v0")
    parser.add_argument("--timesteps", type=float, default=6e6, help="agent-steps at most")
    parser.add_argument("--target", type=float, default=0.95, help="success to stop at")
    parser.add_argument("--window", type=int, default=500, help="agent-episodes")
    parser.add_argument(
        "--curve-window", type=int, default=100, help="agent-episodes per point of the curves"
    )
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument(
        "--deterministic", action="store_true", help="evaluate the policies' mean actions"
    )
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("training_results"))
    args = parser.parse_args(argv)
    from nao_arena.atomic import atomic_write_text
    from nao_arena.envs import available

    envs = [e.strip() for e in args.envs.split(",") if e.strip()]
    unknown = [e for e in envs if e not in available()]
    if unknown or not envs:
        print(f"--envs: unknown env {', '.join(unknown) or '(none)'}", file=sys.stderr)
        return 2
    if not (0 < args.target <= 1 and min(args.window, args.curve_window, args.eval_episodes) >= 1):
        print(
            "--target in (0, 1], --window, --curve-window and --eval-episodes >= 1 expected",
            file=sys.stderr,
        )
        return 2
    jobs = [(e, shield) for e in envs for shield in (False, True)]
    with ProcessPoolExecutor(max(1, args.jobs), mp_context=get_context("spawn")) as pool:
        futures = [
            pool.submit(
                run_one,
                e,
                shield,
                int(args.timesteps),
                args.target,
                args.window,
                args.eval_episodes,
                args.deterministic,
                args.seed,
                args.out,
            )
            for e, shield in jobs
        ]
        results = [f.result() for f in futures]
    for r in results:
        r["curve"] = curve_points(r["episodes"], args.curve_window)
    args.out.mkdir(parents=True, exist_ok=True)
    text = table(results)
    print(text)
    atomic_write_text(args.out / "training.md", text)
    atomic_write_text(args.out / "training.json", json.dumps(results, indent=1) + "\n")
    for e in envs:
        plot(results, e, args.out / f"curves_{e}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
