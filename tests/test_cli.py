"""The nao-arena command: maps, agents, run, trial, report (in-process via main())."""

from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path

import pytest

from nao_arena.cli import main
from nao_arena.maps import available_maps
from nao_arena.report import REPORT_FILES

SMALL = ["--set", "n=4", "--time-limit", "25"]


def test_maps_and_agents(capsys):
    assert main(["maps"]) == 0
    out = capsys.readouterr().out
    for name in available_maps():
        assert f"{name}:" in out
    assert "parameters: n=10" in out
    assert main(["agents"]) == 0
    out = capsys.readouterr().out
    from nao_arena.agent import BUILTIN_AGENTS, BUILTIN_DESCRIPTIONS

    assert BUILTIN_DESCRIPTIONS.keys() == BUILTIN_AGENTS.keys()
    for name in BUILTIN_AGENTS:  # each with what it does, lane included
        (line,) = [ln for ln in out.splitlines() if ln.split()[:2] == [name, "built-in"]]
        assert BUILTIN_DESCRIPTIONS[name] in line and BUILTIN_AGENTS[name] in line


def test_run_prints_the_episode(capsys, tmp_path):
    summary = tmp_path / "episode.json"
    code = main(
        ["run", "circle_swap", "--agent", "nao", "--seed", "3", *SMALL, "--json", str(summary)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "map circle_swap" in out and "4 robots" in out
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("robot"))
    robots = lines[head + 2 : head + 6]
    assert [r.split()[:3] for r in robots] == [[f"swap{k}", "nao", "yes"] for k in range(4)]
    data = json.loads(summary.read_text())
    assert len(data["robots"]) == 4 and all(r["success"] for r in data["robots"])


def test_run_errors(capsys, monkeypatch):
    assert main(["run", "no_such_map"]) == 2
    assert "circle_swap" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--agent", "no_such_agent"]) == 2
    assert "nao, ao, vo, orca, cbf, goal" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--set", "nn=3"]) == 2
    assert "declared: n, radius" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--render", "gif"]) == 2
    assert "--out" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--render", "mp4", "--out", "x.gif"]) == 2
    assert ".mp4" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "nao_arena.render", None)
    assert main(["run", "circle_swap", "--render", "gif", "--out", "x.gif"]) == 2
    assert "rendering is not available" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["run", "circle_swap", "--seed", "x"], "argument --seed: invalid int value: 'x'"),
        (["run"], "the following arguments are required: map"),
        (["bogus"], "invalid choice: 'bogus'"),
        (["trial", "--no-such-option"], "unrecognized arguments: --no-such-option"),
    ],
)
def test_a_command_line_argparse_refuses_is_one_line_and_status_2(capsys, argv, said):
    """Arguments argparse itself refuses: one line naming the argument (no usage block),
    exit status 2."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and said in lines[0] and "--help" in lines[0], captured.err
    assert captured.out == ""


@pytest.mark.slow
def test_trial_then_report(capsys, tmp_path):
    out = tmp_path / "results"
    code = main(
        [
            "trial",
            "--map",
            "circle_swap_perturbed",
            "--agent",
            "goal,nao",
            "--episodes",
            "2",
            "--seed",
            "1",
            "--workers",
            "1",
            "--out",
            str(out),
            "--csv",
            *SMALL,
        ]
    )
    assert code == 0
    captured = capsys.readouterr()
    assert "episodes 4/4" in captured.err and "collisions" in captured.err
    table = captured.out
    assert "collision rate [95% CI]" in table
    rows = [line.split() for line in table.splitlines() if line.startswith("circle_swap")]
    assert [r[1] for r in rows] == ["goal", "nao"]
    summary = json.loads((out / "summary.json").read_text())
    assert [r["episodes"] for r in summary] == [2, 2]
    assert (out / "summary.csv").is_file()

    # resuming runs nothing new and reprints the same table
    assert (
        main(
            [
                "trial",
                "--map",
                "circle_swap_perturbed",
                "--agent",
                "goal,nao",
                "--episodes",
                "2",
                "--seed",
                "1",
                "--out",
                str(out),
                "--quiet",
                *SMALL,
            ]
        )
        == 0
    )
    again = capsys.readouterr()
    assert again.out.splitlines()[:-1] == table.splitlines()[:-1]
    assert "0 episodes run, 4 already done" in again.out

    assert main(["report", str(out)]) == 0
    report = capsys.readouterr().out
    assert report.splitlines()[:4] == table.splitlines()[:4]
    for name in REPORT_FILES:
        png = out / name
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert png.stat().st_size > 10_000


def test_trial_and_report_errors(capsys, tmp_path):
    assert (
        main(["trial", "--map", "circle_swap,nope", "--agent", "nao", "--out", str(tmp_path)]) == 2
    )
    assert "no such map" in capsys.readouterr().err
    assert (
        main(
            [
                "trial",
                "--map",
                "circle_swap",
                "--agent",
                "nao",
                "--set",
                "seed=2",
                "--out",
                str(tmp_path),
            ]
        )
        == 2
    )
    assert "--seed" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "empty")]) == 2
    assert "summary.json" in capsys.readouterr().err


def test_figures_still_listed():
    with pytest.raises(SystemExit) as exc:
        main(["figures", "--help"])
    assert exc.value.code == 0


def _parent_pid(pid: str) -> int | None:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return int(fh.read().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return None


def _running(pid: str) -> bool:
    """Whether process ``pid`` exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            return "zombie" not in fh.read().lower()
    except OSError:
        return False


@pytest.mark.installed
@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals and /proc")
def test_sigterm_stops_a_trial_and_its_workers(tmp_path):
    """SIGTERM ends a running trial like Ctrl-C: exit 130, no worker left running."""
    import os
    import signal
    import subprocess
    import time

    out = tmp_path / "res"
    code = "import sys; from nao_arena.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            code,
            "trial",
            "--map",
            "two_lane_road",
            "--agent",
            "nao",
            "--episodes",
            "8",
            "--workers",
            "2",
            "--out",
            str(out),
            "--quiet",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        cwd=tmp_path,  # outside the source tree: import the installed package
    )
    children: list[str] = []
    deadline = time.monotonic() + 120
    while (
        time.monotonic() < deadline
        and proc.poll() is None
        and not ((out / "trial.json").exists() and children)
    ):
        time.sleep(0.2)
        children = [d for d in os.listdir("/proc") if d.isdigit() and _parent_pid(d) == proc.pid]
    if not children:
        proc.kill()
        pytest.fail(f"no worker processes; the trial said: {proc.communicate()[1]}")
    time.sleep(2.0)  # the workers are running episodes now (one takes tens of seconds)
    assert proc.poll() is None
    os.kill(proc.pid, signal.SIGTERM)
    try:  # running episodes are abandoned, not finished (they take longer)
        _, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert "run the same command again to resume" in err
    deadline = time.monotonic() + 30  # the workers end a moment later on a busy machine
    while (alive := [pid for pid in children if _running(pid)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not alive


# --------------------------------------------------------------------------- bad input


def _one_line_error(capsys) -> str:
    """The command's stderr, checked to be one `nao-arena: error:` line; returns it."""
    err = capsys.readouterr().err
    assert err.startswith("nao-arena: error: ") and err.count("\n") == 1, err
    return err


TINY = ["--set", "n=2"]


@pytest.mark.parametrize(
    ("option", "value", "expected"),
    [
        ("--time-limit", "nan", "a number of seconds > 0 and <= 100000, got nan"),
        ("--time-limit", "inf", "a number of seconds > 0 and <= 100000, got inf"),
        ("--time-limit", "-1", "a number of seconds > 0 and <= 100000, got -1.0"),
        ("--time-limit", "0", "a number of seconds > 0 and <= 100000, got 0.0"),
        ("--seed", "-1", "an integer >= 0, got -1"),
        ("--max-steps", "0", "an integer >= 1, got 0"),
        ("--fps", "0", "a finite number > 0, got 0.0"),
        ("--fps", "nan", "a finite number > 0, got nan"),
    ],
)
def test_run_rejects_numbers_out_of_range(capsys, tmp_path, option, value, expected):
    record = ["--render", "gif", "--out", str(tmp_path / "x.gif")] if option == "--fps" else []
    assert main(["run", "circle_swap", *TINY, *record, option, value]) == 2
    assert f"error: {option}: expected {expected}" in _one_line_error(capsys)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("option", "value", "expected"),
    [
        ("--time-limit", "nan", "a number of seconds > 0 and <= 100000, got nan"),
        ("--time-limit", "inf", "a number of seconds > 0 and <= 100000, got inf"),
        ("--time-limit", "-1", "a number of seconds > 0 and <= 100000, got -1.0"),
        ("--time-limit", "0", "a number of seconds > 0 and <= 100000, got 0.0"),
        ("--seed", "-1", "an integer >= 0, got -1"),
        ("--episodes", "0", "an integer >= 1, got 0"),
        ("--workers", "0", "an integer >= 1, got 0"),
    ],
)
def test_trial_rejects_numbers_out_of_range(capsys, tmp_path, option, value, expected):
    out = tmp_path / "res"
    assert (
        main(
            [
                "trial",
                "--map",
                "circle_swap",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--out",
                str(out),
                "--quiet",
                *TINY,
                option,
                value,
            ]
        )
        == 2
    )
    assert f"error: {option}: expected {expected}" in _one_line_error(capsys)
    assert not out.exists()


def test_outputs_below_a_file_are_one_line_errors(capsys, tmp_path):
    """A parent that is a regular file cannot hold the output, whoever runs the command."""
    afile = tmp_path / "afile"
    afile.write_text("not a folder")
    cases = [
        (["run", "circle_swap", *TINY, "--json", str(afile / "x.json")], f"{afile} is not a"),
        (
            ["run", "circle_swap", *TINY, "--render", "gif", "--out", str(afile / "d" / "x.gif")],
            f"{afile} is not a folder",
        ),
        (
            ["run", "circle_swap", *TINY, "--json", str(tmp_path)],
            "expected a file, got an existing folder",
        ),
        (
            [
                "trial",
                "--map",
                "circle_swap",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--quiet",
                "--out",
                str(afile / "res"),
                *TINY,
            ],
            f"{afile} is not a folder",
        ),
        (
            [
                "trial",
                "--map",
                "circle_swap",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--quiet",
                "--out",
                str(afile),
                *TINY,
            ],
            "expected a folder, got an existing file",
        ),
    ]
    for argv, expected in cases:
        assert main(argv) == 2, argv
        assert expected in _one_line_error(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root may write into a read-only folder"
)
def test_read_only_output_folder_is_a_one_line_error(capsys, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        for argv in (
            ["run", "circle_swap", *TINY, "--json", str(ro / "x.json")],
            ["run", "circle_swap", *TINY, "--render", "gif", "--out", str(ro / "x.gif")],
            [
                "trial",
                "--map",
                "circle_swap",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--quiet",
                "--out",
                str(ro / "res"),
                *TINY,
            ],
        ):
            assert main(argv) == 2, argv
            assert f"no permission to write in {ro}" in _one_line_error(capsys)
    finally:
        ro.chmod(0o700)


def _map_with_robot(tmp_path, **robot) -> str:
    path = tmp_path / "m.yaml"
    fields = ", ".join(f"{k}: {v}" for k, v in robot.items())
    path.write_text(
        "bounds: {min: [-5.0, -5.0], max: [5.0, 5.0]}\n"
        f"robots:\n  - {{start: [0.0, 0.0], goal: [2.0, 0.0], {fields}}}\n"
    )
    return str(path)


@pytest.mark.parametrize(
    ("robot", "field"),
    [
        ({"agent": "superbot"}, "robots[0].agent: expected one of nao"),
        ({"predictor": "crystal_ball"}, "robots[0].predictor: expected one of constant_velocity"),
    ],
)
def test_unknown_names_in_a_map_are_one_line_errors(capsys, tmp_path, robot, field):
    path = _map_with_robot(tmp_path, **robot)
    assert main(["run", path]) == 2
    assert f"{path}: {field}" in _one_line_error(capsys)
    # the map is wrong even when --agent replaces its agents
    assert (
        main(
            [
                "trial",
                "--map",
                path,
                "--agent",
                "nao",
                "--episodes",
                "1",
                "--quiet",
                "--out",
                str(tmp_path / "res"),
            ]
        )
        == 2
    )
    assert f"{path}: {field}" in _one_line_error(capsys)


def test_agent_references_that_fail_to_load_are_one_line_errors(capsys, tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("class Broken:\n    def act(self, obs)\n        return obs\n")
    raising = tmp_path / "raising.py"
    raising.write_text("raise RuntimeError('no licence server\\nsecond line')\n")
    missing = tmp_path / "missing.py"
    for ref, expected in [
        (f"{broken}:Broken", "cannot be loaded (SyntaxError: "),
        (f"{raising}:Agent", "cannot be loaded (RuntimeError: no licence server)"),
        (f"{missing}:Agent", "no such file"),
    ]:
        path = _map_with_robot(tmp_path, agent=f"'{ref}'")
        assert main(["run", path, "--trust-map"]) == 2, ref
        assert f"agent {ref}: " in (err := _one_line_error(capsys)) and expected in err
        assert (
            main(
                [
                    "trial",
                    "--map",
                    "circle_swap",
                    "--agent",
                    ref,
                    "--quiet",
                    "--out",
                    str(tmp_path / "res"),
                    *TINY,
                ]
            )
            == 2
        ), ref
        assert f"agent {ref}: " in (err := _one_line_error(capsys)) and expected in err


# --------------------------------------------------------------------------- newcomer


def test_version(capsys):
    from nao_arena import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"nao-arena {__version__}\n"


def _schema_models():
    """Every pydantic model a map file reaches from its top level, and the builders' args."""
    import typing

    from pydantic import BaseModel

    from nao_arena.maps import LAYOUTS, _MapFile

    found, todo = [], [_MapFile]
    while todo:
        model = todo.pop()
        if model in found:
            continue
        found.append(model)
        for info in model.model_fields.values():
            stack = [info.annotation]
            while stack:
                tp = stack.pop()
                if isinstance(tp, type) and issubclass(tp, BaseModel):
                    todo.append(tp)
                stack.extend(typing.get_args(tp))
    return found + [model for model, _ in LAYOUTS.values()]


def test_maps_schema_documents_every_field(capsys):
    import nao_arena.maps as maps

    assert main(["maps", "--schema"]) == 0
    out = capsys.readouterr().out
    assert out == maps.format_reference() + "\n"
    sections = dict((model, where) for where, model in maps._sections())
    quoted = " ".join(re.findall(r"``(.+?)``", maps.__doc__, re.S))  # the written description
    for model in _schema_models():
        assert model in sections, f"{model.__name__} has no section in the reference"
        table = out.split(f"\n{sections[model]}\n", 1)[1].split("\n\n", 1)[0]
        for name in model.model_fields:
            assert re.search(rf"^  {name} ", table, re.M), f"{sections[model]}: {name}"
            assert re.search(rf"\b{name}\b", quoted), f"{model.__name__}.{name} undocumented"
    assert "`bounds`: `min: [x, y]`" in out and ":data:" not in out


def test_maps_and_run_header_grammar_and_map_origin(capsys, tmp_path):
    from nao_arena.cli import _plural

    assert (_plural(1, "robot"), _plural(0, "robot"), _plural(2, "robot")) == (
        "1 robot",
        "0 robots",
        "2 robots",
    )
    assert main(["run", "circle_swap", "--set", "n=1", "--time-limit", "1"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert ", 1 robot, 0 traffic vehicles; 10 steps," in head
    shipped = re.search(r"\(shipped map, (.+?)\)", head).group(1)
    assert shipped.endswith("circle_swap.yaml") and os.path.isfile(shipped)
    path = _map_with_robot(tmp_path, name="solo")
    assert main(["run", path, "--time-limit", "1"]) == 0
    assert capsys.readouterr().out.startswith(f"map m ({path}), seed 0, 1 robot,")
    assert main(["maps"]) == 0
    out = capsys.readouterr().out
    assert " 1 robots" not in out and "nao-arena maps --schema" in out


@pytest.mark.skipif(sys.platform.startswith(("darwin", "win")), reason="X11/Wayland displays")
def test_render_human_needs_a_display_and_no_out(capsys, monkeypatch, tmp_path):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    assert main(["run", "circle_swap", *TINY, "--render", "human"]) == 2
    err = _one_line_error(capsys)
    assert "cannot open a window: no display" in err and "--render gif --out" in err
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    assert main(["run", "circle_swap", *TINY, "--render", "human"]) == 2
    assert "SDL_VIDEODRIVER=dummy" in _one_line_error(capsys)
    out = tmp_path / "x.gif"
    assert main(["run", "circle_swap", *TINY, "--render", "human", "--out", str(out)]) == 2
    assert f"drop --out, or record with --render gif --out {out}" in _one_line_error(capsys)
    assert not out.exists()


def test_agent_labels_in_run(capsys):
    assert main(["run", "circle_swap", "--agent", "g=goal", *TINY, "--time-limit", "1"]) == 0
    out = capsys.readouterr().out
    assert [line.split()[1] for line in out.splitlines() if line.startswith("swap")] == ["g", "g"]
    for bad, expected in [
        ("nao=goal", "agent label 'nao' is the name of the agent"),
        ("=goal", "expected NAME=REFERENCE"),
        ("g=", "expected NAME=REFERENCE"),
        ("g=nope", "nope"),
    ]:
        assert main(["run", "circle_swap", "--agent", bad, *TINY]) == 2, bad
        assert expected in _one_line_error(capsys)


def test_agent_labels_in_trial_files_tables_and_resume(capsys, tmp_path):
    out = tmp_path / "res"
    argv = [
        "trial",
        "--map",
        "circle_swap",
        "--episodes",
        "1",
        "--quiet",
        "--out",
        str(out),
        *TINY,
        "--time-limit",
        "1",
    ]
    assert main([*argv, "--agent", "nao,g=goal"]) == 0
    table = capsys.readouterr().out
    assert [r.split()[1] for r in table.splitlines() if r.startswith("circle_swap")] == ["nao", "g"]
    assert [r["agent"] for r in json.loads((out / "summary.json").read_text())] == ["nao", "g"]
    assert json.loads((out / "trial.json").read_text())["agent_refs"] == {"g": "goal"}
    assert sorted(p.name for p in (out / "episodes").iterdir()) == [
        "circle_swap__g__00000.json",
        "circle_swap__nao__00000.json",
    ]
    record = json.loads((out / "episodes" / "circle_swap__g__00000.json").read_text())
    assert record["key"]["agent"] == "g" and record["error"] is None
    # the same label for another agent is another trial
    assert main([*argv, "--agent", "nao,g=orca"]) == 2
    assert "agent_refs {'g': 'goal'} there, {'g': 'orca'} now" in _one_line_error(capsys)
    # repeated: resumed, nothing runs
    assert main([*argv, "--agent", "nao,g=goal"]) == 0
    assert "0 episodes run, 2 already done" in capsys.readouterr().out


def test_results_folders_without_agent_labels_still_resume(capsys, tmp_path):
    """trial.json written before labels existed (no agent_refs key) is the same trial."""
    out = tmp_path / "res"
    argv = [
        "trial",
        "--map",
        "circle_swap",
        "--agent",
        "goal",
        "--episodes",
        "1",
        "--quiet",
        "--out",
        str(out),
        *TINY,
        "--time-limit",
        "1",
    ]
    assert main(argv) == 0
    settings = json.loads((out / "trial.json").read_text())
    del settings["agent_refs"]
    (out / "trial.json").write_text(json.dumps(settings))
    capsys.readouterr()
    assert main(argv) == 0
    assert "0 episodes run, 1 already done" in capsys.readouterr().out


def test_split_agent_and_trial_config_labels(tmp_path):
    from nao_arena.trials import TrialConfig, split_agent

    assert split_agent("nao") == ("nao", "nao")
    assert split_agent(" mine = pkg.mod:Mine ") == ("mine", "pkg.mod:Mine")
    assert split_agent("path/x=y.py:A") == ("path/x=y.py:A", "path/x=y.py:A")
    assert split_agent("pkg.mod:A") == ("pkg.mod:A", "pkg.mod:A")
    config = TrialConfig(
        maps=("circle_swap",), agents=("nao", "mine"), agent_refs={"mine": "goal"}, out=tmp_path
    )
    assert (config.reference("mine"), config.reference("nao")) == ("goal", "nao")
    with pytest.raises(ValueError, match="'other' is not one of the agents"):
        TrialConfig(maps=("m",), agents=("nao",), agent_refs={"other": "goal"})
    with pytest.raises(ValueError, match="expected a short name"):
        TrialConfig(maps=("m",), agents=("a/b",), agent_refs={"a/b": "goal"})


def test_compile_messages_on_stderr_only_in_the_command_line(capsys, monkeypatch):
    """The kernels' compile messages are printed on stderr by the command line only."""
    import numba

    import nao_arena.cli as cli
    import nao_arena.kernels as kernels

    numba.njit(lambda x: x + 1)(1)  # a library user compiling: nothing printed
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(kernels._CLOCK, "last_compile", -math.inf)  # a burst starts

    def compiling_command(args):
        numba.njit(lambda x: x + 2)(1)
        numba.njit(lambda x: x + 3)(1)
        print("listed")
        return 0

    monkeypatch.setattr(cli, "_cmd_agents", compiling_command)
    assert main(["agents"]) == 0
    out, err = capsys.readouterr()
    assert out == "listed\n"
    assert err.count("nao-arena: compiling kernels") == 1
    numba.njit(lambda x: x + 4)(1)  # after the command: no handler left
    assert capsys.readouterr().err == ""


def test_no_compile_messages_when_the_kernels_are_cached(capsys):
    argv = ["run", "circle_swap", "--agent", "nao", *TINY, "--time-limit", "1"]
    assert main(argv) == 0  # compiles whatever is not cached yet
    capsys.readouterr()
    assert main(argv) == 0
    assert "compil" not in capsys.readouterr().err


def test_run_and_trial_compile_ahead_what_they_need(capsys, monkeypatch, tmp_path):
    """When the cache lacks some of their kernels, run and trial compile those of their
    agents ahead of time, once, before any episode (in the trial: not in each worker);
    run of a shipped map only those that the map's recorded episodes call."""
    import nao_arena.kernels as kernels

    calls = []
    monkeypatch.setattr(kernels, "missing_kernels", lambda parts: ["x"])

    def compile_ahead(parts, jobs=None, on_done=None):
        calls.append(list(parts))
        kernels.LOG.info("compiled 1/1 kernels")
        return kernels.CompileReport(kernels=1, failed={}, jobs=2, seconds=0.5)

    monkeypatch.setattr(kernels, "compile_ahead", compile_ahead)
    assert main(["run", "circle_swap", "--agent", "goal", *TINY, "--time-limit", "1"]) == 0
    # a shipped map: only what its recorded episodes call
    assert calls == [["core", "goal", kernels.map_part("circle_swap")]]
    assert "nao-arena: compiled 1/1 kernels" in capsys.readouterr().err
    argv = [
        "trial",
        "--map",
        "circle_swap",
        "--agent",
        "goal,nao",
        "--episodes",
        "1",
        "--quiet",
        *TINY,
        "--time-limit",
        "1",
        "--workers",
        "2",
    ]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    assert calls[1:] == [["core", "goal", "nao"]]
    # a map file of the user's (even one named as a shipped map): every kernel of the agents
    mine = tmp_path / "circle_swap.yaml"
    mine.write_text((Path(__file__).parents[1] / "maps" / "circle_swap.yaml").read_text())
    assert main(["run", str(mine), "--agent", "goal", *TINY, "--time-limit", "1"]) == 0
    assert calls[2:] == [["core", "goal"]]


def test_compile_refuses_unknown_agents(capsys):
    assert main(["compile", "--agent", "nao,bogus"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nao-arena: error: --agent: expected built-in agents")
    assert "bogus" in err and len(err.splitlines()) == 1
    assert main(["compile", "--jobs", "0"]) == 2


def test_the_trial_table_names_a_map_file_by_its_name(tmp_path, capsys):
    path = tmp_path / "scene_v2_final.yaml"
    path.write_text(
        "name: doorway_study\n"
        "bounds: {min: [-5.0, -5.0], max: [5.0, 5.0]}\n"
        "robots:\n  - {start: [0.0, 0.0], goal: [2.0, 0.0]}\n"
    )
    argv = [
        "trial",
        "--map",
        str(path),
        "--agent",
        "goal",
        "--episodes",
        "1",
        "--time-limit",
        "1",
        "--out",
        str(tmp_path / "out"),
        "--quiet",
    ]
    assert main(argv) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].startswith("map") and table[2].startswith("doorway_study ")
