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
import contextlib
import io
import logging
import math
import os
import signal
import sys
import time
from collections.abc import Iterable, Iterator
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nao_arena import __version__

if TYPE_CHECKING:  # the CLI imports its heavy parts when a command needs them
    from nao_arena.maps import MapSpec

RENDER_SUFFIX = {"gif": ".gif", "mp4": ".mp4"}


def _err(message: str) -> int:
    print(f"nao-arena: error: {message}", file=sys.stderr)
    return 2


def _split(text: str) -> tuple[str, ...]:
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _plural(n: int, noun: str, nouns: str | None = None) -> str:
    """``1 robot``, ``2 robots`` (``nouns``: the plural, if not ``noun`` + s)."""
    return f"{n} {noun}" if n == 1 else f"{n} {nouns or noun + 's'}"


# --------------------------------------------------------------------------- compiling


@contextlib.contextmanager
def _compile_messages() -> Iterator[None]:
    """While the block runs: the kernels' compile messages (:mod:`nao_arena.kernels`,
    INFO) are printed on stderr as ``nao-arena: ...``."""
    from nao_arena.kernels import LOG, watch_compiles

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("nao-arena: %(message)s"))
    handler.setLevel(logging.INFO)
    level = LOG.level
    LOG.addHandler(handler)
    LOG.setLevel(logging.INFO)
    watch_compiles()
    try:
        yield
    finally:
        LOG.removeHandler(handler)
        LOG.setLevel(level)


class _CompileProgress:
    """``on_done`` of :func:`nao_arena.kernels.compile_ahead`: one line on stderr at
    most every :data:`~nao_arena.kernels.PROGRESS_INTERVAL` s (and at the end): kernels
    done of all, seconds so far."""

    def __init__(self) -> None:
        self.started = time.monotonic()
        self.shown = -math.inf

    def __call__(self, done: int, total: int, key: str) -> None:
        now = time.monotonic()
        from nao_arena.kernels import PROGRESS_INTERVAL

        if done < total and now - self.shown < PROGRESS_INTERVAL:
            return
        self.shown = now
        name = key.partition("(")[0]
        print(
            f"nao-arena: compiled {done}/{total} kernels in {now - self.started:.0f} s "
            f"(last: {name})",
            file=sys.stderr,
            flush=True,
        )


def compile_parts(parts: list[str], jobs: int | None = None, force: bool = False) -> None:
    """Compile the kernels of ``parts`` ahead of time in ``jobs`` processes (default:
    every core) when the cache lacks some of them (``force``: look at each anyway),
    with progress on stderr; nothing when they are cached or when the environment sets
    ``NAO_ARENA_COMPILE_AHEAD=0``."""
    from nao_arena.kernels import compile_ahead, ensure_compiled

    progress = _CompileProgress()
    report = (
        compile_ahead(parts, jobs, on_done=progress)
        if force
        else ensure_compiled(parts, jobs, on_done=progress)
    )
    if report is None:
        return
    failed = f"; {len(report.failed)} left to compile when called" if report.failed else ""
    print(
        f"nao-arena: {report.kernels} kernels compiled or loaded in {report.seconds:.0f} s "
        f"({report.cpu_seconds:.0f} s of CPU) "
        f"with {report.jobs} process{'es' if report.jobs > 1 else ''} (cached for later "
        f"runs){failed}",
        file=sys.stderr,
        flush=True,
    )


def _parts(agents: Iterable[str], render: bool = False) -> list[str]:
    """The kernel parts (:mod:`nao_arena.kernels`) of an episode with these agents."""
    from nao_arena.kernels import parts_for_agents

    return [*parts_for_agents(agents), *(["render"] if render else [])]


def _cmd_compile(args: argparse.Namespace) -> int:
    from nao_arena.agent import BUILTIN_AGENTS
    from nao_arena.kernels import RECORD_PARTS, parts_for_agents

    if args.jobs is not None and args.jobs < 1:
        return _err(f"--jobs: expected an integer >= 1, got {args.jobs}")
    parts = list(RECORD_PARTS)
    if args.agent:
        unknown = [a for a in _split(args.agent) if a not in BUILTIN_AGENTS]
        if unknown:
            return _err(
                f"--agent: expected built-in agents ({', '.join(BUILTIN_AGENTS)}), "
                f"got {', '.join(unknown)}"
            )
        parts = parts_for_agents(_split(args.agent))
    compile_parts(parts, args.jobs, force=True)
    return 0


def _timeout(text: str) -> float | None:
    """``--episode-timeout``: seconds >= 0, or ``none`` / 0 for no budget."""
    if text.strip().lower() in ("none", "0", ""):
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds >= 0 (0 or none: no budget), got {text!r}"
        )
    return value or None


def _overrides(items: list[str] | None) -> dict[str, Any]:
    from nao_arena.maps import parse_overrides

    return parse_overrides(items or [])


_RANGES = {  # option -> (expectation, test) of the numbers of `run` and `trial`
    "seed": ("an integer >= 0", lambda v: v >= 0),
    "time_limit": ("a number of seconds > 0 and <= 100000", lambda v: 0 < v <= 1e5),
    "max_steps": ("an integer >= 1", lambda v: v >= 1),
    "fps": ("a finite number > 0", lambda v: 0 < v < math.inf),
    "episodes": ("an integer >= 1", lambda v: v >= 1),
    "workers": ("an integer >= 1", lambda v: v >= 1),
    "max_faults": ("an integer >= 0", lambda v: v >= 0),
}


def _bad_number(args: argparse.Namespace) -> str | None:
    """The first numeric option given out of its range, as an error message (else None)."""
    for name, (expected, ok) in _RANGES.items():
        value = getattr(args, name, None)
        if value is not None and not ok(value):
            return f"--{name.replace('_', '-')}: expected {expected}, got {value}"
    return None


def _unwritable(path: str, folder: bool = False) -> str | None:
    """Why the output file (or folder) ``path`` cannot be written, as an error message.

    Missing parent folders are created when writing, so the nearest existing
    one must be a folder this process may write into.
    """
    target = Path(path)
    if target.exists() and target.is_dir() != folder:
        want, got = ("a folder", "file") if folder else ("a file", "folder")
        return f"{path}: expected {want}, got an existing {got}"
    place = target if folder and target.exists() else target.parent
    while not place.exists() and place != place.parent:
        place = place.parent
    if not place.is_dir():
        return f"{path}: cannot be written: {place} is not a folder"
    if not os.access(place, os.W_OK | os.X_OK):
        return f"{path}: cannot be written: no permission to write in {place}"
    return None


def _load_agents(refs: Iterable[str]) -> None:
    """Load each agent reference now: a failure is a one-line ValueError before any episode."""
    from nao_arena.agent import load_agent

    for ref in dict.fromkeys(refs):
        try:
            load_agent(ref)
        except ValueError:
            raise
        except Exception as exc:  # noqa: BLE001 - plug-in code may raise anything on import
            first = (str(exc).splitlines() or [""])[0]
            raise ValueError(
                f"agent {ref}: cannot be loaded ({type(exc).__name__}: {first})"
            ) from exc


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


# --------------------------------------------------------------------------- run


def _bodies_line(spec: MapSpec) -> str:
    """``2 robots, 5 people, 30 traffic vehicles`` (people and recorded people only where
    the map has them)."""
    parts = [_plural(spec.n_robots, "robot")]
    if spec.n_people:
        parts.append(_plural(spec.n_people, "person", "people"))
    if spec.n_recorded:
        parts.append(_plural(spec.n_recorded, "recorded person", "recorded people"))
    parts.append(_plural(sum(g.count for g in spec.traffic), "traffic vehicle"))
    return ", ".join(parts)


def people_table(summary: Any) -> str:
    """An episode's per-robot results among people (an EpisodeSummary): contacts with
    people, those the robot caused (it was moving), discomfort (s, and its share of the
    episode) and the closest approach (m)."""
    head = [
        "robot",
        "person contacts",
        "robot-caused",
        "discomfort s",
        "discomfort %",
        "min dist m",
    ]
    body = []
    for r in summary.robots:
        share = 100.0 * r.discomfort_time / summary.duration if summary.duration > 0 else 0.0
        closest = r.min_person_distance
        body.append(
            [
                r.name,
                str(r.person_contacts),
                str(r.caused_person_contacts),
                f"{r.discomfort_time:.1f}",
                f"{share:.1f}",
                f"{closest:.3f}" if closest == closest and abs(closest) != float("inf") else "-",
            ]
        )
    return "among people:\n" + _aligned(head, body)


def episode_table(summary: Any, agents: list[str]) -> str:
    """An episode's per-robot results (an EpisodeSummary) as an aligned text table."""
    head = [
        "robot",
        "agent",
        "success",
        "goal s",
        "path m",
        "collisions",
        "near misses",
        "min sep m",
        "min TTC s",
        "adj/s",
    ]

    def num(v: float, spec: str) -> str:
        return format(v, spec) if v == v and abs(v) != float("inf") else "-"

    body = [
        [
            r.name,
            agents[k] if k < len(agents) else "?",
            "yes" if r.success else "no",
            num(r.time_to_goal, ".1f"),
            num(r.path_length, ".1f"),
            str(r.collisions),
            str(r.near_misses),
            num(r.min_separation, ".3f"),
            num(r.min_ttc, ".2f"),
            num(r.adjustment_rate, ".2f"),
        ]
        for k, r in enumerate(summary.robots)
    ]
    return _aligned(head, body, left=3)


def _aligned(head: list[str], body: list[list[str]], left: int = 1) -> str:
    """A text table: the header, a rule, the rows; the first ``left`` columns aligned
    left, the others right."""
    widths = [max(len(row[i]) for row in [head, *body]) for i in range(len(head))]
    lines = [
        "  ".join(
            c.ljust(w) if i < left else c.rjust(w)
            for i, (c, w) in enumerate(zip(row, widths, strict=True))
        ).rstrip()
        for row in [head, *body]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _no_display() -> str | None:
    """Why a window cannot open here (None if it can, as far as the environment tells)."""
    if os.environ.get("SDL_VIDEODRIVER", "").lower() in ("dummy", "offscreen"):
        return f"SDL_VIDEODRIVER={os.environ['SDL_VIDEODRIVER']} draws off-screen"
    if sys.platform.startswith(("darwin", "win", "cygwin")):
        return None
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return "no display (DISPLAY and WAYLAND_DISPLAY are unset)"
    return None


def _render_problem(args: argparse.Namespace) -> str | None:
    """What is wrong with ``--render``/``--out`` of ``run`` (None: nothing)."""
    if args.render == "human":
        if args.out:
            kind = "mp4" if args.out.lower().endswith(".mp4") else "gif"
            return (
                f"--render human shows a window and writes no file: drop --out, or "
                f"record with --render {kind} --out {args.out}"
            )
        if why := _no_display():
            return (
                f"--render human: cannot open a window: {why}; record the episode "
                "instead with --render gif --out FILE.gif (or mp4)"
            )
    return None


def _map_origin(name: str, source: str) -> str:
    """Where the map came from: its file as given, or the shipped map's installed file."""
    if source == f"maps/{name}.yaml":
        return f"shipped map, {resources.files('nao_arena.maps_data') / f'{name}.yaml'}"
    return source


def _cmd_run(args: argparse.Namespace) -> int:
    from nao_arena.agent import AgentError, describe
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.atomic import remove_stale
    from nao_arena.isolation import EpisodeProcessEnded, run_isolated
    from nao_arena.kernels import preload
    from nao_arena.maps import MapError
    from nao_arena.trials import make_map, split_agent
    from nao_arena.watchdog import EpisodeTimeout
    from nao_arena.world import World

    record: Any = None
    if problem := _bad_number(args) or _render_problem(args):
        return _err(problem)
    if args.render:
        if args.render in RENDER_SUFFIX and not args.out:
            return _err(f"--render {args.render} needs --out FILE{RENDER_SUFFIX[args.render]}")
        if (
            args.out
            and args.render in RENDER_SUFFIX
            and not args.out.lower().endswith(RENDER_SUFFIX[args.render])
        ):
            return _err(
                f"--render {args.render}: expected --out ending in "
                f"{RENDER_SUFFIX[args.render]}, got {args.out}"
            )
        try:
            from nao_arena.render import record_episode

            record = record_episode
        except ImportError as exc:
            return _err(
                f"--render {args.render}: rendering is not available in this "
                f"installation (cannot import nao_arena.render: {exc})"
            )
    elif args.out:
        return _err("--out is the recording's file: use it with --render gif|mp4")
    for path in (args.json, args.out if args.render in RENDER_SUFFIX else None, args.log):
        if path and (problem := _unwritable(path)):
            return _err(problem)
    try:
        label, agent = split_agent(args.agent) if args.agent else (None, None)
        overrides = _overrides(args.set)
        if "seed" in overrides:
            return _err("set the seed with --seed (it seeds the map and the agents)")
        spec = make_map(
            args.map,
            args.seed,
            overrides,
            args.time_limit,
            trusted=args.trust_map,
            agents={label: agent} if label and agent and label != agent else None,
        )
        # --agent replaces the robots' agents; people keep theirs
        refs = sorted({agent if agent and r.kind == "robot" else r.agent for r in spec.robots})
        _load_agents(refs)
        arena = Arena(spec, ArenaOptions(agent=agent, max_faults=args.max_faults))
        if label:
            arena.agent_labels = arena.labels_with(label)
        recorder = _run_recorder(args, arena, label, overrides)
    except (MapError, ValueError) as exc:
        return _err(str(exc))
    parts = _parts(refs, render=bool(args.render))
    # compiled and loaded before the episode's budget starts (which leaves compiles out
    # anyway), here, so that the episode's process starts warm
    compile_parts(parts)
    preload(parts)
    World.warm_up()

    def episode(_: None) -> tuple[int, str, str]:
        if sys.stdout is sys.__stdout__ and sys.stderr is sys.__stderr__:
            return _run_episode(args, arena, spec, label, recorder, record), "", ""
        # this process's streams are replaced (a test, a notebook): what the episode's
        # process prints comes back here
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = _run_episode(args, arena, spec, label, recorder, record)
        return code, out.getvalue(), err.getvalue()

    previous = signal.signal(signal.SIGTERM, _terminate_as_interrupt)
    try:
        code, out, err = run_isolated(episode, None, args.episode_timeout)
    except (AgentError, EpisodeTimeout, EpisodeProcessEnded) as exc:
        return _err(describe(exc))
    except KeyboardInterrupt:
        print("\ninterrupted: the episode was stopped; no output file was written", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGTERM, previous)
        # what the episode's process was writing when it was stopped (temporary files)
        for path in (args.json, args.log, args.out):
            if path:
                remove_stale(path)
    sys.stdout.write(out)
    sys.stderr.write(err)
    return code


def _faults_warning(summary: Any, robots: int) -> str:
    """The loud line under an episode whose agents faulted."""
    names = sorted({f.name for f in summary.faults})
    shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
    return (
        f"nao-arena: warning: {len(summary.faults)} of {summary.steps * robots} "
        f"robot-steps were agent faults ({_plural(len(names), 'robot')}: {shown}); in "
        "those steps the robot got zero acceleration, so the table does not show its "
        "agent's own behaviour. --max-faults N fails an episode past N faults"
    )


def _run_episode(
    args: argparse.Namespace, arena: Any, spec: Any, label: str | None, recorder: Any, record: Any
) -> int:
    """``run``'s episode and its output, in the episode's own process (see
    :mod:`nao_arena.isolation`); returns the exit status."""
    from nao_arena.agent import AgentError, describe
    from nao_arena.watchdog import EpisodeTimeout, wall_clock_budget

    try:
        with wall_clock_budget(args.episode_timeout):
            if args.render:
                arena.reset(args.seed)
                out = None if args.render == "human" else args.out
                result = record(arena, out, fps=args.fps, max_steps=args.max_steps)
                summary = result if hasattr(result, "robots") else arena.summary()
            else:
                summary = arena.run(args.seed, max_steps=args.max_steps)
    except (AgentError, EpisodeTimeout) as exc:
        return _err(describe(exc))
    agents = arena.agent_labels
    print(
        f"map {spec.name} ({_map_origin(args.map, spec.source)}), seed {args.seed}, "
        f"{_bodies_line(spec)}; {_plural(summary.steps, 'step')}, {summary.duration:.1f} s"
    )
    print(episode_table(summary, agents))
    if spec.n_people or spec.n_recorded:
        print(people_table(summary))
    robot_contacts = [c for c in summary.contacts if "robot" in (c.kind_a, c.kind_b)]
    print(f"contacts involving robots: {len(robot_contacts)}; agent faults: {len(summary.faults)}")
    for f in summary.faults[:5]:
        print(f"  fault t={f.time:.1f} s {f.name}: {f.message}")
    if summary.faults:
        print(_faults_warning(summary, len(arena.robots)), file=sys.stderr)
    if args.json:
        try:
            summary.write_json(args.json)
        except OSError as exc:
            return _err(f"{args.json}: cannot be written ({exc.strerror or exc})")
        print(f"wrote {args.json}")
    if args.render and args.render != "human":
        print(f"wrote {args.out}")
    if recorder is not None:
        return _write_run_log(args.log, recorder, arena)
    return 0


# --------------------------------------------------------------------------- trial


def _map_names(config: Any) -> dict[str, str]:
    """The ``name`` of each map file of a trial (by its path), for its table."""
    from nao_arena.trials import make_map

    names = {}
    for ref in config.maps:
        if ref.endswith((".yaml", ".yml")):
            spec = make_map(ref, None, {}, trusted=config.trust_map, agents=config.agent_refs)
            names[ref] = spec.name
    return names


def _terminate_as_interrupt(signum: int, frame: object) -> None:
    """SIGTERM handler: stop a trial like Ctrl-C (workers stopped, finished episodes kept)."""
    raise KeyboardInterrupt


def _cmd_trial(args: argparse.Namespace) -> int:
    from nao_arena.backends import BackendError
    from nao_arena.maps import MapError
    from nao_arena.trials import TrialConfig, format_table, run_trial, split_agent

    for option, key in (("map", "maps"), ("agent", "agents"), ("out", "out")):
        if not getattr(args, option):
            return _err(f"trial: expected --{option} (or {key}: in --config FILE.yaml)")
    if args.address is not None and args.backend != "ray":
        return _err("--address is for the ray backend: add --backend ray")
    if problem := _bad_number(args) or _unwritable(args.out, folder=True):
        return _err(problem)
    try:
        agents = [split_agent(a) for a in _split(args.agent)]
        config = TrialConfig(
            maps=_split(args.map),
            agents=tuple(label for label, _ in agents),
            episodes=args.episodes,
            seed=args.seed,
            workers=args.workers,
            out=Path(args.out),
            overrides=_overrides(args.set),
            time_limit=args.time_limit,
            csv=args.csv,
            retry_failed=args.retry_failed,
            backend=args.backend,
            address=args.address,
            episode_timeout=args.episode_timeout,
            agent_refs={label: ref for label, ref in agents if label != ref},
            log=args.log,
            max_faults=args.max_faults,
            trust_map=args.trust_map,
        )
        _load_agents(config.reference(a) for a in config.agents)
        if args.backend == "local" or args.address is None:
            # compiled once here, before any episode's budget, not in every worker
            compile_parts(_parts(config.reference(a) for a in config.agents))
        previous = signal.signal(signal.SIGTERM, _terminate_as_interrupt)
        try:
            result = run_trial(config, progress=None if args.quiet else sys.stderr)
        finally:
            signal.signal(signal.SIGTERM, previous)
    except (MapError, ValueError, BackendError) as exc:
        return _err(str(exc))
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: finished episodes are kept in {Path(args.out) / 'episodes'}; "
            "run the same command again to resume",
            file=sys.stderr,
        )
        return 130
    print(format_table(result.summary, map_names=_map_names(config)))
    print(f"{result.ran} episodes run, {result.skipped} already done; results in {args.out}")
    if args.log:
        print(_trial_logs_note(Path(args.out)))
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


# --------------------------------------------------------------------------- episode logs


def _run_recorder(
    args: argparse.Namespace, arena: Any, label: str | None, overrides: dict[str, Any]
) -> Any:
    """With ``run --log``: an episode recorder set on the arena (else None)."""
    if not args.log:
        return None
    from nao_arena.episode_log import EpisodeRecorder

    recorder = EpisodeRecorder(
        context={
            "command": "run",
            "map": args.map,
            "seed": args.seed,
            "overrides": overrides,
            "time_limit": args.time_limit,
            "agent": args.agent,
        },
        labels=list(arena.agent_labels),
    )
    arena.recorder = recorder
    return recorder


def _write_run_log(path: str, recorder: Any, arena: Any) -> int:
    from nao_arena.episode_log import write_log

    try:
        write_log(recorder.finish(arena), path)
    except OSError as exc:
        return _err(f"{path}: cannot be written ({exc.strerror or exc})")
    print(
        f"wrote {path} (replay it: nao-arena replay {path}; its contacts: nao-arena explain {path})"
    )
    return 0


def _trial_logs_note(out: Path) -> str:
    logs = sorted((out / "logs").glob("*.parquet")) if (out / "logs").is_dir() else []
    return (
        f"{len(logs)} episode logs in {out / 'logs'} (collisions.parquet names each "
        f"contact's log; nao-arena report {out} lists them)"
    )


def _read_log_or_error(path: str) -> tuple[Any, str | None]:
    """(log, None) or (None, the one-line error)."""
    from nao_arena.episode_log import LogError, read_log

    try:
        return read_log(path), None
    except LogError as exc:
        return None, str(exc)


def _replay_problem(args: argparse.Namespace) -> str | None:
    """What is wrong with the options of ``replay`` (None: nothing)."""
    if args.png and args.render:
        return "--png writes one frame: drop --render (or drop --png to record a video)"
    if args.png and args.at is None:
        return "--png writes the frame at --at T: add --at (s)"
    if args.png and (problem := _unwritable(args.png)):
        return problem
    if args.render in RENDER_SUFFIX:
        if not args.out:
            return f"--render {args.render} needs --out FILE{RENDER_SUFFIX[args.render]}"
        if not args.out.lower().endswith(RENDER_SUFFIX[args.render]):
            return (
                f"--render {args.render}: expected --out ending in "
                f"{RENDER_SUFFIX[args.render]}, got {args.out}"
            )
        return _unwritable(args.out)
    if args.out:
        return "--out is the recording's file: use it with --render gif|mp4"
    if (args.start is not None or args.end is not None) and args.render not in RENDER_SUFFIX:
        return "--from and --to choose the span of a recording: use them with --render gif|mp4"
    if not args.png:
        if why := _no_display():
            return (
                f"replay: cannot open a window: {why}; write a frame with --at T --png "
                "FILE.png or a video with --render gif --out FILE.gif (or mp4)"
            )
    return None


def _cmd_replay(args: argparse.Namespace) -> int:
    if problem := _bad_number(args) or _replay_problem(args):
        return _err(problem)
    log, problem = _read_log_or_error(args.log)
    if problem:
        return _err(problem)
    from nao_arena.render.replay import play, record_replay, robot_index, write_frame

    try:
        selected = robot_index(log, args.robot)
        if args.png:
            print(f"wrote {write_frame(log, args.png, args.at, selected)}")
        elif args.render in RENDER_SUFFIX:
            start = 0.0 if args.start is None else args.start
            print(f"wrote {record_replay(log, args.out, args.fps, start, args.end, selected)}")
        else:
            from nao_arena.explain import explain_contact, explain_picture

            def explain(number: int) -> tuple[str, Any]:
                expl = explain_contact(log, number)
                return expl.text, explain_picture(log, expl)

            play(log, selected, 0.0 if args.at is None else args.at, explain=explain)
    except ValueError as exc:
        return _err(str(exc))
    except OSError as exc:
        return _err(f"cannot write the output: {exc.strerror or exc}")
    return 0


def _contact_list(log: Any, path: str) -> str:
    contacts = log.contacts
    if not contacts:
        return f"{path}: the episode has no contact"
    lines = [f"contacts in {path} (explain one with --contact K):"]
    for k, c in enumerate(contacts, start=1):
        other = f"wall {c.b}" if c.kind_b == "wall" else f"{c.name_b} ({c.kind_b})"
        lines.append(
            f"  {k:3d}  t = {c.time:7.2f} s  {c.name_a} ({c.kind_a}) - {other}  "
            f"{c.impact_speed:.2f} m/s  {1000 * c.max_penetration:.1f} mm"
        )
    return "\n".join(lines)


def _cmd_explain(args: argparse.Namespace) -> int:
    log, problem = _read_log_or_error(args.log)
    if problem:
        return _err(problem)
    if args.contact is None:
        print(_contact_list(log, args.log))
        return 0
    from nao_arena.explain import explain_contact, write_explanation

    out = args.out or str(Path(args.log).with_suffix("")) + f".contact{args.contact}.png"
    if problem := _unwritable(out):
        return _err(problem)
    try:
        expl = explain_contact(log, args.contact)
    except ValueError as exc:
        return _err(f"{args.log}: {exc}")
    print(expl.text)
    try:
        write_explanation(log, expl, out)
    except OSError as exc:
        return _err(f"{out}: cannot be written ({exc.strerror or exc})")
    print(f"wrote {out}")
    return 0


def _add_log_commands(sub: Any) -> None:
    """The ``replay`` and ``explain`` sub-commands."""
    replay = sub.add_parser(
        "replay", help="show an episode log in the viewer, or write a frame or video of it"
    )
    replay.add_argument("log", help="an episode log (run --log FILE, trial --log)")
    replay.add_argument(
        "--robot",
        default=None,
        metavar="R",
        help="robot of the acceleration panel: index or name (default 0)",
    )
    replay.add_argument(
        "--at",
        type=float,
        default=None,
        metavar="T",
        help="time (s): of the frame with --png; where the window starts",
    )
    replay.add_argument(
        "--png", default=None, metavar="FILE", help="write the frame at --at T as a PNG"
    )
    replay.add_argument(
        "--render",
        choices=["human", "gif", "mp4"],
        default=None,
        help="a window (human, the default), or a recording (gif, mp4; with --out)",
    )
    replay.add_argument("--out", default=None, help="recording file (with --render gif|mp4)")
    replay.add_argument(
        "--fps", type=float, default=None, help="recording frame rate (default 1 / dt: every step)"
    )
    replay.add_argument(
        "--from",
        dest="start",
        type=float,
        default=None,
        metavar="S",
        help="recording start (s; default 0)",
    )
    replay.add_argument(
        "--to",
        dest="end",
        type=float,
        default=None,
        metavar="S",
        help="recording end (s; default the episode's end)",
    )
    replay.set_defaults(func=_cmd_replay)

    explain = sub.add_parser(
        "explain", help="why did these two touch? a logged contact, the step before it"
    )
    explain.add_argument("log", help="an episode log (run --log FILE, trial --log)")
    explain.add_argument(
        "--contact",
        type=int,
        default=None,
        metavar="K",
        help="the contact to explain (1 = the first); without it: list them",
    )
    explain.add_argument(
        "--out",
        default=None,
        metavar="FILE.png",
        help="the picture (default: LOG without its suffix + .contactK.png)",
    )
    explain.set_defaults(func=_cmd_explain)


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
    parser = argparse.ArgumentParser(
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
