"""Compare agents on a map: a small trial, its table and its plots.

    python examples/compare_agents.py [--map crossing] [--episodes 5] [--set n=4]
                                      [--time-limit S] [--workers 2] [--out results/compare]

It runs NAO, ORCA, goal seeking (no avoidance) and the custom agent of
examples/custom_agent.py (labelled ``polite``) on the same seeds, prints the
table and writes ``rates.png``, ``time_to_goal.png`` and ``min_separation.png``
into the output folder. The same from the command line:

    nao-arena trial --map crossing --agent nao,orca,goal,polite=examples/custom_agent.py:Polite \\
        --episodes 5 --out results/compare
    nao-arena report results/compare

Run it again with more episodes and only the new ones run (the folder is resumed).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nao_arena.maps import parse_overrides
from nao_arena.report import write_report
from nao_arena.trials import TrialConfig, format_table, run_trial

POLITE = f"{Path(__file__).resolve().with_name('custom_agent.py')}:Polite"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Compare agents on one map.")
    parser.add_argument("--map", default="crossing", help="shipped map name or map file")
    parser.add_argument("--episodes", type=int, default=5, help="episodes per agent")
    parser.add_argument("--seed", type=int, default=0, help="the trial's root seed")
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="KEY=VALUE", help="map parameters, e.g. n=4"
    )
    parser.add_argument("--time-limit", type=float, default=None, metavar="S")
    parser.add_argument("--workers", type=int, default=1, help="local worker processes")
    parser.add_argument("--out", default="results/compare", help="results folder")
    args = parser.parse_args(argv)

    config = TrialConfig(
        maps=(args.map,),
        agents=("nao", "orca", "goal", "polite"),  # the names tables and plots show
        agent_refs={"polite": POLITE},  # label -> what is loaded
        episodes=args.episodes,
        seed=args.seed,
        workers=args.workers,
        out=Path(args.out),
        overrides=parse_overrides(args.set),
        time_limit=args.time_limit,
    )
    result = run_trial(config)
    print(format_table(result.summary, legend=False))
    for path in write_report(args.out):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
