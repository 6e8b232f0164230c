"""The ``replay`` and ``explain`` sub-commands of :mod:`nao_arena.cli`: an episode log in
the viewer, as a frame or a video, and the explanation of one of its contacts."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from nao_arena._cli_common import RENDER_SUFFIX, _bad_number, _err, _no_display, _unwritable


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
