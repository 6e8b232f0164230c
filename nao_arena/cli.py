"""The ``nao-arena`` command line.

Sub-commands::

    nao-arena run MAP [--agent [LABEL=]AGENT] [--seed S] [--set key=value ...]
                  [--time-limit S] [--episode-timeout S] [--max-faults N]
                  [--render human | --render gif|mp4 --out FILE] [--json FILE] [--log FILE]
    nao-arena trial --map MAP[,MAP...] --agent [LABEL=]A[,[LABEL=]B...] --episodes N
                    --seed S --workers W --out DIR [--csv] [--set key=value ...]
                    [--time-limit S] [--episode-timeout S] [--max-faults N]
                    [--backend local|ray [--address ADDR]] [--log [all|contacts]]
    nao-arena report DIR [--out PLOTS_DIR]
    nao-arena replay LOG [--robot R] [--at T [--png FILE]]
                     [--render human | --render gif|mp4 --out FILE [--from S] [--to S]]
    nao-arena explain LOG [--contact K [--out FILE.png]]
    nao-arena maps [--schema]
    nao-arena agents
    nao-arena figures [--out DIR] [--only NAMES]
    nao-arena compile [--agent AGENT,...] [--jobs N]
    nao-arena --version

An agent is a built-in or plug-in name, ``FILE.py:CLASS`` or
``module:CLASS``; ``LABEL=AGENT`` (e.g. ``mine=path/to/mine.py:Mine``) loads
AGENT and shows it as LABEL in tables, plots and results files.

The first command that runs an episode after installing compiles the numba
kernels it needs, in one process per core, before the episode starts, and
caches them; stderr shows the progress. ``nao-arena compile`` compiles every
kernel ahead of time (for images, clusters and CI). A compile never counts
against ``--episode-timeout``.

Errors (unknown map, agent, parameter; a number out of its range, e.g.
``--time-limit`` must be finite and > 0 s and ``--seed`` >= 0; an output
file or folder that cannot be written) are printed on stderr as one line
``nao-arena: error: ...`` naming what was expected, exit status 2; so is a
file that cannot be read or written (a full disk included). ``run`` also exits
2 with a one-line error when an agent's constructor or reset raises, when the
episode exceeds its wall-clock budget (``--episode-timeout``, default 600 s;
0 or none: no budget), when its agents fault more than ``--max-faults`` times,
or when the episode's process ends without a result (each episode runs in a
process of its own, see :mod:`nao_arena.isolation`); a trial records such
episodes as failed and goes on. A map that names code as an agent is refused
unless ``--trust-map`` (see :func:`nao_arena.maps.load_map`). ``run --render
human`` needs a display (and refuses ``--out``).

Episode logs (:mod:`nao_arena.episode_log`): ``run --log FILE`` writes the
episode's log; ``trial --log`` one per episode into ``DIR/logs`` (``--log
contacts``: only the episodes with a contact or a stuck robot). ``replay``
shows a log in the viewer (or writes a PNG, GIF or MP4 of it), ``explain``
explains one of its contacts. A log that cannot be read (missing,
truncated, corrupt, another format version) is a one-line error, exit status 2.
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from nao_arena import __version__
from nao_arena._cli_common import RENDER_SUFFIX as RENDER_SUFFIX
from nao_arena._cli_common import OneLineParser, _err, _timeout
from nao_arena._cli_common import _plural as _plural
from nao_arena._cli_compile import _cmd_compile, _compile_messages
from nao_arena._cli_compile import compile_parts as compile_parts
from nao_arena._cli_episodes import _cmd_run, _cmd_trial
from nao_arena._cli_logs import _add_log_commands
from nao_arena._cli_tables import _bodies_line
from nao_arena._cli_tables import episode_table as episode_table
from nao_arena._cli_tables import people_table as people_table

# --------------------------------------------------------------------------- figures


def _cmd_figures(args: argparse.Namespace) -> int:
    from nao_arena.figures import FIGURES, write_figures

    names = args.only.split(",") if args.only else None
    unknown = [n for n in names or [] if n not in FIGURES]
    if unknown:
        print(
            f"unknown figure(s): {', '.join(unknown)}; choose from {', '.join(FIGURES)}",
            file=sys.stderr,
        )
        return 2
    for path in write_figures(args.out, names):
        print(path)
    return 0


# --------------------------------------------------------------------------- report, lists


def _cmd_report(args: argparse.Namespace) -> int:
    from nao_arena.report import report_text, write_report

    try:
        print(report_text(args.dir))
        paths = write_report(args.dir, args.out)
    except (FileNotFoundError, ValueError) as exc:
        return _err(str(exc))
    for path in paths:
        print(path)
    return 0


def _cmd_maps(args: argparse.Namespace) -> int:
    from nao_arena.maps import MapError, available_maps, format_reference, load_map

    if args.schema:
        print(format_reference())
        return 0
    for name in available_maps():
        try:
            spec = load_map(name)
        except MapError as exc:
            print(f"{name}\n    (cannot be loaded: {exc})")
            continue
        desc = " ".join(spec.description.split())
        params = ", ".join(f"{k}={v}" for k, v in spec.parameters.items()) or "none"
        print(f"{name}: {_bodies_line(spec)}, {spec.episode.time_limit:g} s")
        if desc:
            print(f"    {desc}")
        print(f"    parameters: {params}")
    print(
        "(any map file can be given by its path, e.g. path/to/my_map.yaml; the shipped "
        f"ones are in {resources.files('nao_arena.maps_data')}; the format: "
        "nao-arena maps --schema)"
    )
    return 0


def _cmd_agents(args: argparse.Namespace) -> int:
    from nao_arena.agent import BUILTIN_AGENTS, BUILTIN_DESCRIPTIONS, available_agents

    found = available_agents()
    width = max(len(n) for n in found)
    for name, ref in found.items():
        if name in BUILTIN_AGENTS:
            print(f"{name.ljust(width)}  built-in  {BUILTIN_DESCRIPTIONS[name]} ({ref})")
        else:
            print(f"{name.ljust(width)}  plug-in   {ref}")
    print(
        "(also: path/to/file.py:ClassName or package.module:ClassName; LABEL=AGENT shows "
        "it as LABEL in tables and files)"
    )
    return 0


# --------------------------------------------------------------------------- parser


def _add_map_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--set",
        action="extend",
        nargs="+",
        metavar="KEY=VALUE",
        help="map parameter overrides, e.g. --set n=4 radius=6",
    )
    p.add_argument(
        "--time-limit",
        type=float,
        default=None,
        metavar="S",
        help="episode time limit (s), replacing the map's",
    )
    p.add_argument(
        "--episode-timeout",
        type=_timeout,
        default=600.0,
        metavar="S",
        help="wall-clock budget of an episode (s; default 600; 0 or none: no "
        "budget): an episode that exceeds it fails (a trial goes on)",
    )
    p.add_argument(
        "--trust-map",
        action="store_true",
        help="let the map name code as its robots' agents (path/to/file.py:Class "
        "or module:Class); without it such a map is refused: it would run "
        "that code",
    )
    p.add_argument(
        "--max-faults",
        type=int,
        default=None,
        metavar="N",
        help="an episode whose agents fault (raise, or return no finite "
        "acceleration) more than N times fails (default: never)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="nao-arena", description="Multi-robot testbed built around the NAO."
    )
    parser.add_argument("--version", action="version", version=f"nao-arena {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run one episode and print its summary")
    run.add_argument("map", help="map name (see `nao-arena maps`) or map file path")
    run.add_argument(
        "--agent",
        default=None,
        metavar="[LABEL=]AGENT",
        help="agent of the map's robots (default: the map's own): a name, "
        "FILE.py:CLASS or module:CLASS; LABEL=AGENT shows it as LABEL",
    )
    run.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seeds the map (if it has a seed parameter) and the agents",
    )
    _add_map_options(run)
    run.add_argument("--max-steps", type=int, default=None, help="stop after this many steps")
    run.add_argument(
        "--render",
        choices=["human", "gif", "mp4"],
        default=None,
        help="show the episode in a window (human; needs a display), or "
        "record it (gif, mp4; with --out)",
    )
    run.add_argument("--out", default=None, help="recording file (with --render gif|mp4)")
    run.add_argument("--fps", type=float, default=None, help="recording frame rate")
    run.add_argument(
        "--json", default=None, metavar="FILE", help="also write the episode summary as JSON"
    )
    run.add_argument(
        "--log",
        default=None,
        metavar="FILE",
        help="also write the episode's log (every step; for replay, explain)",
    )
    run.set_defaults(func=_cmd_run)

    trial = sub.add_parser("trial", help="run the grid maps x agents x episodes")
    trial.add_argument(
        "--config",
        default=None,
        metavar="FILE.yaml",
        help="an experiment file holding these options (see nao_arena.trials.experiment); "
        "options given here override its",
    )
    trial.add_argument("--map", default=None, help="comma-separated map names or paths")
    trial.add_argument(
        "--agent",
        default=None,
        metavar="[LABEL=]AGENT,...",
        help="comma-separated agents (names, FILE.py:CLASS, module:CLASS); "
        "LABEL=AGENT names one LABEL in tables, plots and files",
    )
    trial.add_argument("--episodes", type=int, default=10, help="episodes per map x agent")
    trial.add_argument("--seed", type=int, default=0, help="the trial's root seed")
    trial.add_argument(
        "--workers",
        type=int,
        default=1,
        help="local worker processes (with --backend ray and no --address: "
        "the CPUs of the local Ray instance)",
    )
    trial.add_argument(
        "--out",
        default=None,
        help="results folder (resumed if it exists; locked while the trial "
        "runs; refused if it holds a trial with other settings, except "
        "--workers, --backend, --address, --csv, --retry-failed and "
        "more --episodes)",
    )
    trial.add_argument("--csv", action="store_true", help="also write CSV files")
    _add_map_options(trial)
    trial.add_argument(
        "--retry-failed", action="store_true", help="run again the episodes recorded as failed"
    )
    trial.add_argument("--quiet", action="store_true", help="no progress line")
    trial.add_argument(
        "--backend",
        choices=["local", "ray"],
        default="local",
        help="where the episodes run: local processes (default) or Ray tasks "
        "(needs `pip install nao-arena[ray]`)",
    )
    trial.add_argument(
        "--address",
        default=None,
        metavar="ADDR",
        help="with --backend ray: the Ray cluster to connect to (e.g. auto, "
        "HOST:6379, ray://HOST:10001); default: start a local Ray",
    )
    trial.add_argument(
        "--log",
        nargs="?",
        const="all",
        default=None,
        choices=["all", "contacts"],
        help="write each episode's log into OUT/logs (for replay, explain); "
        "--log contacts: only those with a contact or a stuck robot",
    )
    trial.set_defaults(func=_cmd_trial)
    parser.set_defaults(trial_parser=trial)

    report = sub.add_parser("report", help="table and plots of a trial's results")
    report.add_argument("dir", help="a trial's results folder")
    report.add_argument("--out", default=None, help="folder for the PNGs (default: DIR)")
    report.set_defaults(func=_cmd_report)

    maps = sub.add_parser("maps", help="list the shipped maps and their parameters")
    maps.add_argument(
        "--schema",
        action="store_true",
        help="print the map file format instead (every key, type, default)",
    )
    maps.set_defaults(func=_cmd_maps)
    agents = sub.add_parser("agents", help="list the agents (built-in and plug-ins)")
    agents.set_defaults(func=_cmd_agents)

    _add_log_commands(sub)

    comp = sub.add_parser(
        "compile", help="compile the kernels ahead of time into the cache, on every core"
    )
    comp.add_argument(
        "--agent",
        default=None,
        metavar="AGENT,...",
        help="only what episodes with these built-in agents use (default: "
        "everything, rendering included)",
    )
    comp.add_argument("--jobs", type=int, default=None, help="processes (default: one per core)")
    comp.set_defaults(func=_cmd_compile)

    fig = sub.add_parser("figures", help="draw the paper's geometric figures (PNG)")
    fig.add_argument("--out", default="figures", help="output folder (default: figures)")
    fig.add_argument("--only", default="", help="comma-separated figure names")
    fig.set_defaults(func=_cmd_figures)
    return parser


def _experiment_defaults(path: str) -> dict[str, Any]:
    """The options of the experiment file ``path`` as ``trial``'s argparse defaults."""
    import json

    from nao_arena.trials.experiment import read_experiment

    exp = read_experiment(path)
    values = exp.model_dump()
    values["map"] = ",".join(values.pop("maps"))
    values["agent"] = ",".join(values.pop("agents"))
    values["set"] = [f"{k}={json.dumps(v)}" for k, v in values.pop("set").items()]
    return values


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "config", None):
        from nao_arena.maps import MapError

        try:
            args.trial_parser.set_defaults(**_experiment_defaults(args.config))
        except MapError as exc:
            return _err(str(exc))
        args = parser.parse_args(argv)
    try:
        with _compile_messages():
            return int(args.func(args))
    except BrokenPipeError:  # the reader went away (`nao-arena maps --schema | head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # a file or folder that cannot be read or written, a full disk
        return _err(_os_error(exc, args))
    except MemoryError:
        return _err(
            "out of memory: the map or the settings ask for more than this machine "
            "has (fewer robots, a shorter episode or a longer dt need less)"
        )


def _os_error(exc: OSError, args: argparse.Namespace) -> str:
    """One line for an OSError no command handled: the file, what failed, and for a trial
    what is kept."""
    where = exc.filename if exc.filename is not None else "a file"
    what = exc.strerror or type(exc).__name__
    text = f"{where}: cannot be written or read ({what})"
    if args.command == "trial":
        text += (
            f"; the episodes finished so far are kept in {Path(args.out) / 'episodes'}: "
            "free space (or fix the folder) and run the same command again to resume"
        )
    return text


if __name__ == "__main__":
    raise SystemExit(main())
