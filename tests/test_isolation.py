"""Process-level agent faults end at most their episode (:mod:`nao_arena.isolation`):
``os._exit``, ``fork``, a SIGALRM handler that ignores the budget, a non-daemon thread,
the trial's main process killed; an agent that faults every step; a class that is no agent."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from nao_arena.agent import TooManyFaults, check_agent_class, load_agent
from nao_arena.arena import Arena, ArenaOptions, make_agent
from nao_arena.cli import main
from nao_arena.isolation import GRACE, EpisodeProcessEnded, isolation_enabled, run_isolated
from nao_arena.maps import load_map
from nao_arena.trials import EpisodeTask, TrialConfig, compute_episode, run_trial
from nao_arena.watchdog import EpisodeTimeout

pytestmark = pytest.mark.skipif(not isolation_enabled(), reason="no os.fork on this platform")

HOSTILE = """
import os, signal, threading, time
import numpy as np

class Exits:
    def reset(self, spec, rng):
        pass

    def act(self, obs):
        if obs.time > 0.25:
            os._exit(0)
        return np.zeros(2)

class Forks:
    def reset(self, spec, rng):
        self.forked = False

    def act(self, obs):
        if not self.forked and obs.time > 0.25:
            self.forked = True
            child = os.fork()
            if child:  # the parent records the fork: the fork itself may be ended first
                with open(os.environ["FORK_MARKER"], "a") as fh:
                    fh.write(f"{child}\\n")
        return np.ones(2)

class Spins:
    def reset(self, spec, rng):
        signal.signal(signal.SIGALRM, signal.SIG_IGN)

    def act(self, obs):
        while True:
            pass

class Lingers:
    def reset(self, spec, rng):
        threading.Thread(target=time.sleep, args=(3600,), daemon=False).start()

    def act(self, obs):
        return np.zeros(2)

class Raises:
    def reset(self, spec, rng):
        pass

    def act(self, obs):
        raise RuntimeError("no plan")

class NoAct:
    def reset(self, spec, rng):
        pass
"""


@pytest.fixture
def hostile(tmp_path: Path) -> str:
    path = tmp_path / "hostile.py"
    path.write_text(textwrap.dedent(HOSTILE))
    return str(path)


def task(tmp_path: Path, agent: str, timeout: float | None = 20.0, **kw) -> EpisodeTask:
    return EpisodeTask(
        map="circle_swap",
        agent=agent,
        episode=0,
        seed=0,
        overrides={"n": 2},
        time_limit=2.0,
        path=str(tmp_path / "x.json"),
        episode_timeout=timeout,
        **kw,
    )


def one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    return err


RUN = ["--set", "n=2", "--time-limit", "2"]


# --------------------------------------------------------------------------- the primitive


def test_a_call_in_its_own_process_returns_its_value_and_raises_its_exception():
    assert run_isolated(sorted, [3, 1, 2]) == [1, 2, 3]
    with pytest.raises(ZeroDivisionError):
        run_isolated(lambda x: 1 / x, 0)
    with pytest.raises(EpisodeTimeout, match="budget of 7 s") as info:
        run_isolated(lambda _: (_ for _ in ()).throw(EpisodeTimeout(7.0)), None)
    assert info.value.seconds == 7.0
    # what the child changes stays in the child
    seen: list[int] = []
    run_isolated(seen.append, 1)
    assert seen == []


def test_a_child_that_ends_without_a_value_is_reported_with_its_status():
    with pytest.raises(EpisodeProcessEnded, match="exited with status 3"):
        run_isolated(os._exit, 3)
    with pytest.raises(EpisodeProcessEnded, match="was killed by SIGKILL"):
        run_isolated(lambda _: os.kill(os.getpid(), signal.SIGKILL), None)


def test_the_budget_is_enforced_from_outside():
    def ignores_the_alarm(_: None) -> None:
        signal.signal(signal.SIGALRM, signal.SIG_IGN)
        while True:
            pass

    start = time.monotonic()
    with pytest.raises(EpisodeTimeout, match="budget of 0.5 s"):
        run_isolated(ignores_the_alarm, None, budget=0.5)
    assert time.monotonic() - start >= 0.5


# --------------------------------------------------------------------------- hostile agents


def test_os_exit_in_act_fails_the_episode_not_the_trial(tmp_path, hostile, capsys):
    record = compute_episode(task(tmp_path, f"{hostile}:Exits"))
    assert record["result"] is None
    assert record["error"].startswith(
        "EpisodeProcessEnded: the episode's process exited with status 0"
    )
    assert main(["run", "circle_swap", *RUN, "--agent", f"{hostile}:Exits"]) == 2
    assert one_line(capsys).startswith("nao-arena: error: EpisodeProcessEnded:")
    # a trial records it and goes on to its summary
    config = TrialConfig(
        maps=("circle_swap",),
        agents=("goal", f"{hostile}:Exits"),
        episodes=2,
        out=tmp_path / "out",
        overrides={"n": 2},
        time_limit=2.0,
    )
    result = run_trial(config, progress=None)
    rows = {r["agent"]: r for r in result.summary}
    assert rows[f"{hostile}:Exits"]["failed_episodes"] == 2
    assert rows["goal"]["failed_episodes"] == 0 and result.ran == 4


def test_a_fork_in_act_ends_when_act_returns(tmp_path, hostile, monkeypatch):
    marker = tmp_path / "forked"
    monkeypatch.setenv("FORK_MARKER", str(marker))
    record = compute_episode(task(tmp_path, f"{hostile}:Forks"))
    assert record["error"] is None and record["result"]["steps"] == 20
    forked = [int(p) for p in marker.read_text().split()]
    assert len(forked) == 2  # one per robot; neither runs on
    for pid in forked:
        assert _ends(pid), pid
    # the same episode in this process: its forks end too, and change nothing
    monkeypatch.setenv("FORK_MARKER", str(tmp_path / "forked_here"))
    spec = load_map("circle_swap", n=2).model_copy(
        update={
            "episode": load_map("circle_swap", n=2).episode.model_copy(update={"time_limit": 2.0})
        }
    )
    here = Arena(spec, ArenaOptions(agent=f"{hostile}:Forks")).run(0)
    forked_here = [int(p) for p in (tmp_path / "forked_here").read_text().split()]
    assert len(forked_here) == 2
    for pid in forked_here:  # children of this process: each ended itself, with status 0
        _, status = os.waitpid(pid, 0)
        assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, (pid, status)
    assert here.trajectory_hash == record["result"]["trajectory_hash"]


def _ends(pid: int, deadline_s: float = 30.0) -> bool:
    """Whether process ``pid`` is gone (or a zombie) within ``deadline_s`` seconds: it may be
    killed a moment after the episode that forked it returns."""
    end = time.monotonic() + deadline_s
    while Path(f"/proc/{pid}").exists() and "Z" not in _state(pid):
        if time.monotonic() > end:
            return False
        time.sleep(0.05)
    return True


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"


def test_an_agent_that_blocks_the_alarm_is_stopped_from_outside(tmp_path, hostile, capsys):
    start = time.monotonic()
    record = compute_episode(task(tmp_path, f"{hostile}:Spins", timeout=0.5))
    took = time.monotonic() - start
    assert record["error"] == "EpisodeTimeout: episode exceeded its wall-clock budget of 0.5 s"
    assert took < 0.5 + GRACE + 10.0
    assert (
        main(
            ["run", "circle_swap", *RUN, "--agent", f"{hostile}:Spins", "--episode-timeout", "0.5"]
        )
        == 2
    )
    assert one_line(capsys) == (
        "nao-arena: error: EpisodeTimeout: episode exceeded its wall-clock budget of 0.5 s"
    )


def test_a_thread_left_running_does_not_keep_run_alive(hostile):
    cmd = [
        sys.executable,
        "-m",
        "nao_arena.cli",
        "run",
        "circle_swap",
        *RUN,
        "--agent",
        f"{hostile}:Lingers",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "map circle_swap" in done.stdout


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_killing_a_trial_leaves_no_worker_behind(tmp_path):
    slow = tmp_path / "slow.py"
    slow.write_text(
        "import time\nimport numpy as np\n\nclass Slow:\n"
        "    def reset(self, spec, rng):\n        pass\n\n"
        "    def act(self, obs):\n        time.sleep(0.05)\n"
        "        return np.zeros(2)\n"
    )
    cmd = [
        sys.executable,
        "-m",
        "nao_arena.cli",
        "trial",
        "--map",
        "circle_swap",
        "--set",
        "n=2",
        "--agent",
        f"{slow}:Slow",
        "--episodes",
        "4",
        "--workers",
        "2",
        "--time-limit",
        "60",
        "--out",
        str(tmp_path / "out"),
        "--quiet",
    ]
    main_process = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 240
        family: set[int] = set()
        while time.monotonic() < deadline:
            family = _descendants(main_process.pid)
            if len(family) >= 4:  # two workers, each running an episode's process
                break
            time.sleep(0.2)
        assert len(family) >= 4, family
    finally:
        main_process.kill()
        main_process.wait()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_alive(p) for p in family):
        time.sleep(0.1)
    assert not [p for p in family if _alive(p)]


def _descendants(root: int) -> set[int]:
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parents[int(stat.parent.name)] = int(fields[1])
    found, todo = set(), [root]
    while todo:
        pid = todo.pop()
        for child, parent in parents.items():
            if parent == pid and child not in found:
                found.add(child)
                todo.append(child)
    return found


def _alive(pid: int) -> bool:
    return _state(pid) not in ("gone", "Z")


def test_the_workers_warm_up_is_not_the_episodes(tmp_path):
    """The kernels an episode calls are loaded in the process that watches it, before the
    episode's process starts (and its budget with it)."""
    code = textwrap.dedent(f"""
        from nao_arena.trials import EpisodeTask, compute_episode
        from nao_arena.world import _plan_period
        assert not _plan_period.overloads
        record = compute_episode(EpisodeTask(
            map="circle_swap", agent="nao", episode=0, seed=0, overrides={{"n": 2}},
            time_limit=1.0, path={str(tmp_path / "x.json")!r}, episode_timeout=60.0))
        assert record["error"] is None, record["error"]
        print(len(_plan_period.overloads))
    """)
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split()[-1]) >= 1


# --------------------------------------------------------------------------- faults


def test_too_many_faults_fail_the_episode(tmp_path, hostile, capsys):
    arena = Arena(
        load_map("circle_swap", n=2), ArenaOptions(agent=f"{hostile}:Raises", max_faults=5)
    )
    arena.reset(0)
    for _ in range(2):
        arena.step()  # 4 faults
    with pytest.raises(
        TooManyFaults,
        match="6 agent faults by t = 0.2 s, more than the 5 allowed .* RuntimeError: no plan",
    ):
        arena.step()
    record = compute_episode(task(tmp_path, f"{hostile}:Raises", max_faults=3))
    assert record["error"].startswith("TooManyFaults: 4 agent faults")
    assert (
        main(["run", "circle_swap", *RUN, "--agent", f"{hostile}:Raises", "--max-faults", "0"]) == 2
    )
    assert one_line(capsys).startswith("nao-arena: error: TooManyFaults: 2 agent faults")
    # without a limit the episode runs, and says loudly that it was all faults
    assert main(["run", "circle_swap", *RUN, "--agent", f"{hostile}:Raises"]) == 0
    warning = one_line(capsys)
    assert warning.startswith(
        "nao-arena: warning: 40 of 40 robot-steps were agent faults (2 robots: swap0, swap1)"
    )
    with pytest.raises(ValueError, match="max_faults"):
        ArenaOptions(max_faults=-1)


def test_a_class_that_is_no_agent_is_refused_before_it_is_made(tmp_path, hostile, capsys):
    with pytest.raises(ValueError, match="class NoAct is not an agent: it has no act method"):
        load_agent(f"{hostile}:NoAct")
    with pytest.raises(ValueError, match="it has no reset and no act method"):
        load_agent("collections:OrderedDict")
    with pytest.raises(ValueError, match="expected a class"):
        check_agent_class("os:system", os.system)

    made = []

    class Half:
        def __init__(self) -> None:
            made.append(self)

        def act(self, obs):
            return np.zeros(2)

    robot = load_map("circle_swap", n=2).robots[0]
    with pytest.raises(ValueError, match="it has no reset method"):
        make_agent(Half, robot)
    assert not made
    assert main(["run", "circle_swap", *RUN, "--agent", f"{hostile}:NoAct"]) == 2
    assert "class NoAct is not an agent" in one_line(capsys)


def test_a_trial_records_max_faults_in_its_settings(tmp_path, hostile):
    config = TrialConfig(
        maps=("circle_swap",),
        agents=(f"{hostile}:Raises",),
        episodes=1,
        out=tmp_path / "out",
        overrides={"n": 2},
        time_limit=1.0,
        max_faults=2,
    )
    run_trial(config, progress=None)
    settings = json.loads((tmp_path / "out" / "trial.json").read_text())
    assert settings["max_faults"] == 2
    (record,) = [json.loads(p.read_text()) for p in (tmp_path / "out" / "episodes").glob("*")]
    assert record["key"]["max_faults"] == 2 and record["error"].startswith("TooManyFaults")


# --------------------------------------------------------------------------- killed writers


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGKILL])
def test_a_killed_recording_leaves_no_temporary_file(tmp_path, how):
    out = tmp_path / "episode.gif"
    cmd = [
        sys.executable,
        "-m",
        "nao_arena.cli",
        "run",
        "circle_swap",
        "--set",
        "n=8",
        "--render",
        "gif",
        "--out",
        str(out),
    ]
    process = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and not _temporaries(tmp_path):
        time.sleep(0.1)
    assert _temporaries(tmp_path), "the recording never started"
    process.send_signal(how)
    _, err = process.communicate(timeout=60)
    assert not out.exists()
    if how == signal.SIGTERM:
        assert process.returncode == 130
        assert b"interrupted" in err and b"Traceback" not in err
        assert _temporaries(tmp_path) == []
    else:
        # nothing can clean up after SIGKILL: the next write to that file does
        from nao_arena.atomic import remove_stale

        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not remove_stale(out):
            time.sleep(0.1)
        assert _temporaries(tmp_path) == []


def test_temporary_files_of_live_writers_are_kept(tmp_path):
    from nao_arena.atomic import remove_stale, temporary_sibling

    target = tmp_path / "x.json"
    fd, mine = temporary_sibling(target)
    os.close(fd)
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        alive = tmp_path / f".x.json.{sleeper.pid}.abc.tmp"
        alive.write_text("")
        dead = subprocess.run(
            [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
        ).stdout.strip()
        stale = tmp_path / f".x.json.{dead}.abc.tmp"
        stale.write_text("")
        other = tmp_path / f".y.json.{dead}.abc.tmp"
        other.write_text("")
        assert remove_stale(target) == [stale]
        assert alive.exists() and Path(mine).exists() and other.exists()
    finally:
        sleeper.kill()
        sleeper.wait()


# --------------------------------------------------------------------------- files


def test_a_full_disk_during_a_trial_is_one_line(tmp_path, monkeypatch, capsys):
    import errno

    import nao_arena.trials.run as trial_run

    def full(task, record):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), task.path)

    monkeypatch.setattr(trial_run, "write_record", full)
    out = tmp_path / "out"
    assert (
        main(
            [
                "trial",
                "--map",
                "circle_swap",
                "--set",
                "n=2",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--time-limit",
                "1",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 2
    )
    err = one_line(capsys)
    assert err.startswith("nao-arena: error: ") and "No space left on device" in err
    assert "run the same command again to resume" in err


@pytest.mark.parametrize(
    "command",
    [
        ["figures", "--out", "/proc/nao-arena-x"],
        ["trial", "--map", "circle_swap", "--agent", "goal", "--out", "/proc/nao-arena-x"],
    ],
)
def test_an_output_folder_that_cannot_be_made_is_one_line(command, capsys):
    assert main(command) == 2
    err = one_line(capsys)
    assert err.startswith("nao-arena: error: /proc/nao-arena-x")


def test_absurd_time_limits_are_refused(capsys):
    for value in ("1e300", "1e6"):
        assert main(["run", "circle_swap", "--time-limit", value]) == 2
        assert one_line(capsys).startswith(
            "nao-arena: error: --time-limit: expected a number of seconds > 0 and <= 100000"
        )
    # a time limit within bounds but too many control periods for the map's dt
    from nao_arena.maps import MapError, with_time_limit

    spec = load_map("circle_swap")
    spec = spec.model_copy(update={"physics": spec.physics.model_copy(update={"dt": 0.01})})
    assert with_time_limit(spec, 10_000.0).episode.time_limit == 10_000.0
    with pytest.raises(MapError, match="at most 1000000 control periods"):
        with_time_limit(spec, 10_000.1)
