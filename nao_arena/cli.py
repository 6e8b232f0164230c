"""The ``nao-arena`` command line."""

from __future__ import annotations

import argparse
import sys


def _cmd_figures(args: argparse.Namespace) -> int:
    from nao_arena.figures import FIGURES, write_figures

    names = args.only.split(",") if args.only else None
    unknown = [n for n in names or [] if n not in FIGURES]
    if unknown:
        print(f"unknown figure(s): {', '.join(unknown)}; choose from {', '.join(FIGURES)}",
              file=sys.stderr)
        return 2
    for path in write_figures(args.out, names):
        print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nao-arena", description="Multi-robot testbed built around the NAO."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    fig = sub.add_parser("figures", help="draw the paper's geometric figures (PNG)")
    fig.add_argument("--out", default="figures", help="output folder (default: figures)")
    fig.add_argument("--only", default="", help="comma-separated figure names")
    fig.set_defaults(func=_cmd_figures)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    raise SystemExit(main())
