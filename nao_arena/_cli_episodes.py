"""The ``run`` and ``trial`` sub-commands of :mod:`nao_arena.cli`: their checks, the
episode in its own process and its output, the trial's table, and the episode logs they
write."""

from __future__ import annotations

import argparse
import contextlib
import io
import signal
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from nao_arena._cli_common import (
    RENDER_SUFFIX,
    _bad_number,
    _err,
    _load_agents,
    _no_display,
    _overrides,
    _plural,
    _split,
    _terminate_as_interrupt,
    _unwritable,
)
from nao_arena._cli_compile import _parts, compile_parts
from nao_arena._cli_tables import _bodies_line, episode_table, people_table


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
    from nao_arena.kernels import map_part, preload
    from nao_arena.maps import MapError, available_maps
    from nao_arena.trials import make_map, split_agent
    from nao_arena.watchdog import EpisodeTimeout

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
    if not args.render and args.map in available_maps():
        # a shipped map: only what its recorded episodes call is compiled ahead
        parts.append(map_part(args.map))
    # compiled and loaded before the episode's budget starts (which leaves compiles out
    # anyway), here, so that the episode's process starts warm
    compile_parts(parts)
    preload(parts)
    Arena.warm_up()

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


def _map_names(config: Any) -> dict[str, str]:
    """The ``name`` of each map file of a trial (by its path), for its table."""
    from nao_arena.trials import make_map

    names = {}
    for ref in config.maps:
        if ref.endswith((".yaml", ".yml")):
            spec = make_map(ref, None, {}, trusted=config.trust_map, agents=config.agent_refs)
            names[ref] = spec.name
    return names


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
