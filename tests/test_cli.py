"""The nao-arena command: maps, agents, run, trial, report (in-process via main())."""

from __future__ import annotations

import json
import sys

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
    for name in ("nao", "ao", "vo", "orca", "goal"):
        assert any(line.split()[:2] == [name, "built-in"] for line in out.splitlines())


def test_run_prints_the_episode(capsys, tmp_path):
    summary = tmp_path / "episode.json"
    code = main(["run", "circle_swap", "--agent", "nao", "--seed", "3", *SMALL,
                 "--json", str(summary)])
    assert code == 0
    out = capsys.readouterr().out
    assert "map circle_swap" in out and "4 robots" in out
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("robot"))
    robots = lines[head + 2: head + 6]
    assert [r.split()[:3] for r in robots] == [[f"swap{k}", "nao", "yes"] for k in range(4)]
    data = json.loads(summary.read_text())
    assert len(data["robots"]) == 4 and all(r["success"] for r in data["robots"])


def test_run_errors(capsys, monkeypatch):
    assert main(["run", "no_such_map"]) == 2
    assert "circle_swap" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--agent", "no_such_agent"]) == 2
    assert "nao, ao, vo, orca, goal" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--set", "nn=3"]) == 2
    assert "declared: n, radius" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--render", "gif"]) == 2
    assert "--out" in capsys.readouterr().err
    assert main(["run", "circle_swap", "--render", "mp4", "--out", "x.gif"]) == 2
    assert ".mp4" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "nao_arena.render", None)
    assert main(["run", "circle_swap", "--render", "gif", "--out", "x.gif"]) == 2
    assert "rendering is not available" in capsys.readouterr().err


def test_trial_then_report(capsys, tmp_path):
    out = tmp_path / "results"
    code = main(["trial", "--map", "circle_swap_perturbed", "--agent", "goal,nao",
                 "--episodes", "2", "--seed", "1", "--workers", "1", "--out", str(out),
                 "--csv", *SMALL])
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
    assert main(["trial", "--map", "circle_swap_perturbed", "--agent", "goal,nao",
                 "--episodes", "2", "--seed", "1", "--out", str(out), "--quiet", *SMALL]) == 0
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
    assert main(["trial", "--map", "circle_swap,nope", "--agent", "nao",
                 "--out", str(tmp_path)]) == 2
    assert "no such map" in capsys.readouterr().err
    assert main(["trial", "--map", "circle_swap", "--agent", "nao", "--set", "seed=2",
                 "--out", str(tmp_path)]) == 2
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


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals and /proc")
def test_sigterm_stops_a_trial_and_its_workers(tmp_path):
    """SIGTERM ends a running trial like Ctrl-C: exit 130, no worker left running."""
    import os
    import signal
    import subprocess
    import time

    out = tmp_path / "res"
    code = ("import sys; from nao_arena.cli import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "trial", "--map", "two_lane_road", "--agent", "nao",
         "--episodes", "8", "--workers", "2", "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        cwd=tmp_path,  # outside the source tree: import the installed package
    )
    children: list[str] = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None and not (
        (out / "trial.json").exists() and children
    ):
        time.sleep(0.2)
        children = [d for d in os.listdir("/proc")
                    if d.isdigit() and _parent_pid(d) == proc.pid]
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
    time.sleep(0.5)
    alive = [pid for pid in children if os.path.exists(f"/proc/{pid}")
             and "zombie" not in open(f"/proc/{pid}/status").read().lower()]
    assert not alive
