"""Trials: seeds, determinism across worker counts, resume, failed episodes, summary.json,
counts beside rates, repeated episodes, the output folder's lock and settings."""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nao_arena import trials
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.cli import main
from nao_arena.maps import MapError
from nao_arena.stats import ContactEvent, RobotSummary
from nao_arena.trials import (
    SUMMARY_KEYS,
    TABLE_LEGEND,
    ResultsFolderError,
    TrialConfig,
    episode_path,
    episode_seed,
    format_table,
    make_map,
    run_trial,
    summarize,
    wilson_interval,
)

SMALL = {"n": 4}
STABLE_KEYS = {
    "map",
    "agent",
    "episodes",
    "robots",
    "collisions",
    "collision_rate",
    "collision_rate_ci95",
    "success_rate",
    "median_time_to_goal_s",
    "min_separation_m",
    "adjustments_per_s",
}


def small(out: Path, workers: int = 1, **kw) -> TrialConfig:
    settings = dict(
        maps=("circle_swap_perturbed",),
        agents=("goal", "nao"),
        episodes=2,
        seed=7,
        workers=workers,
        out=out,
        overrides=SMALL,
        time_limit=15.0,
    )
    settings.update(kw)
    return TrialConfig(**settings)


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory) -> tuple[Path, list[dict]]:
    out = tmp_path_factory.mktemp("w1")
    result = run_trial(small(out, csv=True), progress=None)
    assert result.ran == 4 and result.skipped == 0
    return out, result.summary


def test_episode_seeds_depend_on_map_and_episode_only():
    a = episode_seed(0, "roundabout", 3)
    assert a == episode_seed(0, "roundabout", 3)
    assert 0 <= a < 2**32
    seeds = {episode_seed(0, m, e) for m in ("roundabout", "crowd") for e in range(50)}
    assert len(seeds) == 100
    assert episode_seed(1, "roundabout", 3) != a


def test_wilson_interval():
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and 0.2 < hi < 0.35
    lo, hi = wilson_interval(10, 10)
    assert hi == 1.0 and 0.65 < lo < 0.8
    lo, hi = wilson_interval(5, 10)
    assert lo < 0.5 < hi and math.isclose(lo + hi, 1.0)


def test_files_and_summary(one_worker):
    out, summary = one_worker
    for name in (
        "episodes.parquet",
        "collisions.parquet",
        "summary.json",
        "trial.json",
        "episodes.csv",
        "collisions.csv",
        "summary.csv",
    ):
        assert (out / name).is_file(), name
    assert len(list((out / "episodes").glob("*.json"))) == 4
    assert not list(out.rglob("*.tmp"))
    assert json.loads((out / "summary.json").read_text()) == summary
    assert [(r["map"], r["agent"]) for r in summary] == [
        ("circle_swap_perturbed", "goal"),
        ("circle_swap_perturbed", "nao"),
    ]
    episodes = pq.read_table(out / "episodes.parquet")
    assert episodes.num_rows == 2 * 2 * 4
    robot_fields = {f for f in RobotSummary.__dataclass_fields__ if f != "name"}
    assert {"map", "agent", "episode", "seed", "robot", "error"} | robot_fields <= set(
        episodes.column_names
    )
    contacts = pq.read_table(out / "collisions.parquet")
    assert {"map", "agent", "episode", "seed"} | set(ContactEvent.__dataclass_fields__) <= set(
        contacts.column_names
    )
    rows = episodes.to_pylist()
    for row in summary:
        assert set(SUMMARY_KEYS) <= set(row) and STABLE_KEYS <= set(row)
        assert row["episodes"] == 2 and row["robots"] == 8 and row["failed_episodes"] == 0
        for key in ("collision_rate", "success_rate"):
            lo, hi = row[f"{key}_ci95"]
            assert 0.0 <= lo <= row[key] <= hi <= 1.0
        cell = [r for r in rows if r["agent"] == row["agent"]]
        assert row["collision_rate"] == sum(r["collisions"] > 0 for r in cell) / len(cell)
        assert row["adjustments_per_s"] >= 0
        assert row["collisions"] == sum(
            1
            for c in contacts.to_pylist()
            if c["agent"] == row["agent"] and "robot" in (c["kind_a"], c["kind_b"])
        )
    by_agent = {r["agent"]: r for r in summary}
    # the goal seekers drive into each other in the middle; NAO does not
    assert by_agent["goal"]["collision_rate"] == 1.0
    assert by_agent["nao"]["collision_rate"] == 0.0 and by_agent["nao"]["success_rate"] == 1.0
    assert 5.0 < by_agent["nao"]["median_time_to_goal_s"] < 15.0
    assert by_agent["nao"]["min_separation_m"] > 0.0 > by_agent["goal"]["min_separation_m"]
    # every agent faces the same scenes: seeds per (map, episode)
    seeds = {(r["agent"], r["episode"]): r["seed"] for r in rows}
    assert seeds[("goal", 0)] == seeds[("nao", 0)] != seeds[("goal", 1)]
    assert "circle_swap_perturbed" in format_table(summary)


@pytest.mark.installed
@pytest.mark.slow
def test_same_results_with_two_workers(one_worker, tmp_path):
    out1, summary1 = one_worker
    result = run_trial(small(tmp_path, workers=2, csv=True), progress=None)
    assert result.summary == summary1
    assert (tmp_path / "summary.json").read_bytes() == (out1 / "summary.json").read_bytes()
    for name in ("episodes.parquet", "collisions.parquet"):
        assert pq.read_table(tmp_path / name).equals(pq.read_table(out1 / name))
    assert (tmp_path / "episodes.csv").read_bytes() == (out1 / "episodes.csv").read_bytes()


def test_resume_recomputes_only_missing_episodes(tmp_path):
    config = small(tmp_path)
    first = run_trial(config, progress=None)
    files = sorted((tmp_path / "episodes").glob("*.json"))
    stamps = {f: f.stat().st_mtime_ns for f in files}
    victim = episode_path(tmp_path, "circle_swap_perturbed", "nao", 1)
    victim.unlink()
    (tmp_path / "summary.json").unlink()
    ran: list[tuple[str, int]] = []
    second = run_trial(
        config,
        progress=None,
        on_episode=lambda rec: ran.append((rec["key"]["agent"], rec["key"]["episode"])),
    )
    assert ran == [("nao", 1)] and second.ran == 1 and second.skipped == 3
    for f in files:
        if f != victim:
            assert f.stat().st_mtime_ns == stamps[f]
    assert second.summary == first.summary
    # a different root seed is a different trial: refused in the same folder
    with pytest.raises(ResultsFolderError, match="seed 7 there, 8 now"):
        run_trial(small(tmp_path, seed=8), progress=None)


def test_crashed_episode_is_recorded(tmp_path):
    bad = tmp_path / "bad_agent.py"
    bad.write_text(
        "class Broken:\n"
        "    def __init__(self):\n"
        "        raise RuntimeError('cannot start')\n"
        "    def reset(self, spec, rng):\n"
        "        pass\n"
        "    def act(self, obs):\n"
        "        return obs.velocity\n"
    )
    agent = f"{bad}:Broken"
    config = small(tmp_path / "out", agents=("goal", agent), episodes=1)
    result = run_trial(config, progress=None)
    rows = {r["agent"]: r for r in result.summary}
    assert rows[agent]["failed_episodes"] == 1 and rows[agent]["robots"] == 0
    assert rows[agent]["collision_rate"] is None
    assert rows["goal"]["failed_episodes"] == 0 and rows["goal"]["robots"] == 4
    table = pq.read_table(tmp_path / "out" / "episodes.parquet").to_pylist()
    failed = [r for r in table if r["agent"] == agent]
    assert len(failed) == 1 and "RuntimeError: cannot start" in failed[0]["error"]
    assert failed[0]["robot"] is None
    assert all(r["error"] is None for r in table if r["agent"] == "goal")
    assert "1 failed" in format_table(result.summary)


def test_clear_errors(tmp_path):
    with pytest.raises(MapError, match="roundabout"):
        run_trial(small(tmp_path, maps=("no_such_map",)), progress=None)
    with pytest.raises(ValueError, match="nao, ao"):
        run_trial(small(tmp_path, agents=("no_such_agent",)), progress=None)
    with pytest.raises(MapError, match="no map declares it"):
        run_trial(small(tmp_path, overrides={"nn": 3}), progress=None)
    with pytest.raises(ValueError, match="--seed"):
        small(tmp_path, overrides={"seed": 3})
    with pytest.raises(ValueError, match="workers"):
        small(tmp_path, workers=0)
    assert not os.path.exists(tmp_path / "summary.json")


# --------------------------------------------------------------------------- trajectory hash


def test_trajectory_hash_is_the_sha256_of_positions_and_velocities():
    arena = Arena(make_map("circle_swap_perturbed", 3, SMALL), ArenaOptions(agent="goal"))
    digest = hashlib.sha256()

    def add(state) -> None:
        digest.update(np.asarray(state.positions, dtype=np.float64).tobytes())
        digest.update(np.asarray(state.velocities, dtype=np.float64).tobytes())

    add(arena.reset(3))
    for _ in range(30):
        add(arena.step().state)
    summary = arena.summary()
    assert summary.trajectory_hash == digest.hexdigest()
    assert summary.to_dict()["trajectory_hash"] == digest.hexdigest()
    # the hash changes no number of the summary
    plain = arena.stats.summary().to_dict()
    assert plain.pop("trajectory_hash") == ""
    result = summary.to_dict()
    result.pop("trajectory_hash")
    assert json.dumps(result) == json.dumps(plain)
    again = Arena(make_map("circle_swap_perturbed", 3, SMALL), ArenaOptions(agent="goal"))
    assert again.run(3, max_steps=30).trajectory_hash == summary.trajectory_hash
    other = Arena(make_map("circle_swap_perturbed", 4, SMALL), ArenaOptions(agent="goal"))
    assert other.run(4, max_steps=30).trajectory_hash != summary.trajectory_hash


# --------------------------------------------------------------------------- counts


def _robot(collided: bool, arrived: bool = True) -> dict:
    return {
        "index": 0,
        "name": "r",
        "reached_goal": arrived,
        "success": arrived and not collided,
        "time_to_goal": 10.0 if arrived else None,
        "path_length": 10.0,
        "collisions": int(collided),
        "wall_collisions": 0,
        "near_misses": 0,
        "min_separation": 0.5,
        "min_ttc": None,
        "adjustments": 2,
        "adjustment_rate": 0.2,
    }


def _record(
    episode: int,
    collided: int,
    robots: int = 10,
    digest: str | None = None,
    duration: float = 3600.0,
) -> dict:
    """A synthetic episode record: ``collided`` of ``robots`` robots touched a wall once."""
    contact = {"kind_a": "robot", "kind_b": "wall"}
    return {
        "key": {"map": "m", "agent": "a", "episode": episode},
        "error": None,
        "result": {
            "duration": duration,
            "steps": 100,
            "robots": [_robot(k < collided) for k in range(robots)],
            "contacts": [contact] * collided,
            "faults": [],
            "trajectory_hash": f"{episode:064x}" if digest is None else digest,
        },
    }


def test_summary_counts_beside_every_rate_and_small_rates_never_read_zero():
    records = [_record(e, 1 if e < 5 else 0) for e in range(440)]  # 5 of 4400 collided
    (row,) = summarize(records)
    assert set(SUMMARY_KEYS) <= set(row)
    assert row["robots"] == 4400 and row["robots_collided"] == 5 and row["collisions"] == 5
    assert row["collision_rate"] == 5 / 4400
    assert row["robots_succeeded"] == 4395 and row["success_rate"] == 4395 / 4400
    assert row["robots_arrived"] == 4400 and row["distinct_episodes"] == 440
    assert row["distinct_robots"] == 4400
    assert row["adjustments"] == 8800 and row["driven_s"] == 44000.0
    assert row["adjustments_per_s"] == row["adjustments"] / row["driven_s"]
    assert row["collision_rate_ci95"] == list(wilson_interval(5, 4400))
    table = format_table([row])
    line = table.splitlines()[2]
    assert "5/4400 (0.11 %)" in line and "4395/4400 (99.89 %)" in line
    low, high = wilson_interval(5, 4400)
    assert f"[{100 * low:.3f}, {100 * high:.2f}] %" in line
    # 5 contacts in 4400 robot-hours: not "0.0"
    assert " 0.0011 " in line and " 0.0 " not in line and "0.000" not in line


def test_summary_keys_are_documented_and_the_legend_defines_every_column():
    for key in SUMMARY_KEYS:
        assert f"``{key}``" in trials.__doc__, key
    head = format_table([]).splitlines()[0]
    for column in (
        "episodes",
        "distinct",
        "success",
        "collision rate",
        "contacts",
        "contacts/robot-h",
        "median TTG s",
        "min sep m",
        "adj/s",
    ):
        assert column in head
        assert any(line.strip().startswith(f"{column}:") for line in TABLE_LEGEND.splitlines())
    assert TABLE_LEGEND in format_table([])
    assert TABLE_LEGEND not in format_table([], legend=False)


@given(st.integers(1, 10**7), st.integers(0, 10**7))
def test_percent_of_a_count_is_zero_or_hundred_only_when_it_is(count, extra):
    text = trials.table._percent(count / (count + extra))
    assert float(text) > 0.0
    assert (float(text) < 100.0) == (extra > 0)
    assert (float(trials.table._percent(extra / (count + extra))) == 0.0) == (extra == 0)


def test_non_zero_numbers_in_the_table_never_read_zero():
    assert trials.table._num(0.004, 1) == "0.004" and trials.table._num(-1e-4, 3) == "-0.0001"
    assert trials.table._num(0.0, 3) == "0.000" and trials.table._num(None, 1) == "-"
    assert trials.table._num(2.345, 2) == "2.35"


# --------------------------------------------------------------------------- repeats


def test_repeated_episodes_are_detected_and_counted_once_in_the_intervals():
    same = "ab" * 32
    records = [_record(e, 2, robots=4, digest=same) for e in range(5)]  # 5 exact repeats
    (row,) = summarize(records)
    assert row["distinct_episodes"] == 1 and row["distinct_robots"] == 4
    assert row["robots"] == 20 and row["robots_collided"] == 10 and row["collision_rate"] == 0.5
    assert row["collision_rate_ci95"] == list(wilson_interval(2, 4))
    assert row["success_rate_ci95"] == list(wilson_interval(2, 4))
    text = format_table([row])
    assert "note: m x a: 5 episodes but only 1 distinct trajectory " in text
    assert "take the 4 robot-episodes of distinct episodes as the sample size" in text
    # records from before the hash existed count as distinct
    for rec in records:
        rec["result"].pop("trajectory_hash")
    (row,) = summarize(records)
    assert row["distinct_episodes"] == 5 and "note:" not in format_table([row])


def test_a_trial_of_a_map_without_randomness_reports_its_repeats(tmp_path):
    config = TrialConfig(
        maps=("circle_swap",),
        agents=("goal",),
        episodes=3,
        seed=0,
        out=tmp_path,
        overrides={"n": 4},
        time_limit=2.0,
    )
    (row,) = run_trial(config, progress=None).summary
    assert row["episodes"] == 3 and row["distinct_episodes"] == 1
    assert row["robots"] == 12 and row["distinct_robots"] == 4
    assert "only 1 distinct trajectory " in format_table([row])


def test_distinct_episodes_of_a_seeded_map(one_worker):
    _, summary = one_worker
    for row in summary:
        assert row["distinct_episodes"] == 2 and row["distinct_robots"] == row["robots"] == 8
        assert row["collision_rate_ci95"] == list(
            wilson_interval(row["robots_collided"], row["robots"])
        )


# --------------------------------------------------------------------------- the output folder


def quick(out: Path, **kw) -> TrialConfig:
    settings = dict(
        maps=("circle_swap_perturbed",),
        agents=("goal",),
        episodes=1,
        seed=7,
        out=out,
        overrides=SMALL,
        time_limit=3.0,
    )
    settings.update(kw)
    return TrialConfig(**settings)


def test_a_second_trial_on_a_folder_in_use_fails_at_once(tmp_path, capsys):
    refused: list[str] = []

    def meanwhile(record: dict) -> None:
        if refused:
            return
        with pytest.raises(ResultsFolderError) as info:
            run_trial(quick(tmp_path, seed=8), progress=None)
        refused.append(str(info.value))
        args = [
            "trial",
            "--map",
            "circle_swap_perturbed",
            "--agent",
            "goal",
            "--episodes",
            "1",
            "--seed",
            "7",
            "--out",
            str(tmp_path),
            "--set",
            "n=4",
            "--time-limit",
            "3",
        ]
        assert main(args) == 2
        refused.append(capsys.readouterr().err)

    first = run_trial(quick(tmp_path, episodes=2), progress=None, on_episode=meanwhile)
    assert first.ran == 2
    message, cli_error = refused
    assert str(tmp_path) in message and f"pid {os.getpid()}" in message
    assert cli_error.count("\n") == 1 and "in use by another trial" in cli_error
    # the lock ends with the trial
    assert run_trial(quick(tmp_path, episodes=2), progress=None).skipped == 2


def test_other_settings_in_the_same_folder_are_refused(tmp_path, capsys):
    run_trial(quick(tmp_path), progress=None)
    before = {name: (tmp_path / name).read_bytes() for name in ("trial.json", "summary.json")}
    with pytest.raises(ResultsFolderError, match=r"seed 7 there, 8 now.*another --out"):
        run_trial(quick(tmp_path, seed=8), progress=None)
    with pytest.raises(ResultsFolderError, match="time_limit 3.0 there, 4.0 now"):
        run_trial(quick(tmp_path, time_limit=4.0), progress=None)
    with pytest.raises(ResultsFolderError, match="overrides"):
        run_trial(quick(tmp_path, overrides={"n": 5}), progress=None)
    with pytest.raises(ResultsFolderError, match="agents"):
        run_trial(quick(tmp_path, agents=("goal", "nao")), progress=None)
    assert (
        main(
            [
                "trial",
                "--map",
                "circle_swap_perturbed",
                "--agent",
                "goal",
                "--episodes",
                "1",
                "--seed",
                "8",
                "--out",
                str(tmp_path),
                "--set",
                "n=4",
                "--time-limit",
                "3",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(tmp_path) in err and "seed 7 there, 8 now" in err
    assert {name: (tmp_path / name).read_bytes() for name in before} == before
    # settings that do not change results may differ
    again = run_trial(quick(tmp_path, csv=True, retry_failed=True), progress=None)
    assert again.ran == 0 and again.skipped == 1


def test_more_episodes_extend_the_folder_and_keep_the_earlier_rows(tmp_path):
    first = run_trial(quick(tmp_path), progress=None)
    more = run_trial(quick(tmp_path, episodes=3), progress=None)
    assert more.ran == 2 and more.skipped == 1
    (row,) = more.summary
    assert row["episodes"] == 3 and row["robots"] == 12
    rows = pq.read_table(tmp_path / "episodes.parquet").to_pylist()
    assert sorted({r["episode"] for r in rows}) == [0, 1, 2]
    earlier = [r for r in rows if r["episode"] == 0]
    assert sum(r["collisions"] > 0 for r in earlier) == first.summary[0]["robots_collided"]
    assert json.loads((tmp_path / "trial.json").read_text())["episodes"] == 3
    with pytest.raises(ResultsFolderError, match="episodes 2 < 3 \\(episodes may only grow\\)"):
        run_trial(quick(tmp_path, episodes=2), progress=None)


def test_an_unreadable_trial_json_is_refused(tmp_path):
    (tmp_path / "trial.json").write_text("{not json")
    with pytest.raises(ResultsFolderError, match="trial.json: cannot read it"):
        run_trial(quick(tmp_path), progress=None)


def test_report_table_shows_counts_and_the_legend(one_worker, tmp_path):
    from nao_arena.report import rate_label, report_text

    out, summary = one_worker
    text = report_text(out)
    by_agent = {
        line.split()[1]: line
        for line in text.splitlines()
        if line.startswith("circle_swap_perturbed")
    }
    assert "8/8 (100 %) [" in by_agent["goal"] and "0/8 (0 %)" in by_agent["goal"]
    assert TABLE_LEGEND in text
    assert [rate_label(r) for r in summary] == ["8/8", "0/8"]
    # a summary.json from before the counts: counts from rate x robots
    old = [
        {
            k: v
            for k, v in row.items()
            if k in STABLE_KEYS | {"failed_episodes", "success_rate_ci95"}
        }
        for row in summary
    ]
    (tmp_path / "summary.json").write_text(json.dumps(old))
    goal_line = report_text(tmp_path).splitlines()[2]
    assert goal_line.split()[1] == "goal" and "8/8 (100 %) [" in goal_line
    assert [rate_label(r) for r in old] == ["8/8", "0/8"]


def test_liveness_counts_in_the_summary_and_the_table():
    """Timed-out, stuck, left-the-goal and deadlocked robot-episodes are counted from the
    episode records (records without the liveness fields count as none)."""

    def robot(arrived: bool, stuck: float, away: float, at_end: bool) -> dict:
        return {
            **_robot(False, arrived),
            "stuck_time": stuck,
            "time_away_after_arrival": away,
            "at_goal_at_end": at_end,
            "final_goal_distance": 0.1 if at_end else 2.0,
            "timed_out": not arrived,
        }

    records = [_record(e, 0, robots=0) for e in range(3)]
    records[0]["result"]["robots"] = [robot(True, 0.0, 0.0, True), robot(False, 12.0, 0.0, False)]
    records[0]["result"]["deadlock_time"] = 31.5
    records[1]["result"]["robots"] = [robot(True, 3.0, 4.0, False), robot(True, 0.0, 1.0, True)]
    records[1]["result"]["deadlock_time"] = None
    records[2]["result"]["robots"] = [_robot(False), _robot(False)]  # an older record
    (row,) = summarize(records)
    assert row["robots"] == 6 and row["robots_timed_out"] == 1
    assert row["robots_stuck"] == 2 and row["stuck_s"] == 15.0
    assert row["robots_left_goal"] == 2 and row["robots_away_at_end"] == 1
    assert row["episodes_deadlocked"] == 1
    table = format_table([row])
    head, _, cells = table.splitlines()[:3]
    assert "timed out" in head and "deadlocks" in head
    assert "1/6 (16.7 %)" in cells and cells.split()[-3:] == ["2", "2", "1"]
    assert "deadlocks: episodes with a time at which" in table


def test_trial_config_rejects_non_finite_time_limits():
    for bad in (math.inf, math.nan, 0.0, -1.0):
        with pytest.raises(ValueError, match="time limit"):
            TrialConfig(maps=("crossing",), agents=("goal",), time_limit=bad)


def _nao_imports(module: object) -> dict[str, list[str]]:
    """{imported nao_arena module: names} of a module's source (all import statements)."""
    import ast
    import inspect

    out: dict[str, list[str]] = {}
    for node in ast.walk(ast.parse(inspect.getsource(module))):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("nao_arena"):
            out.setdefault(node.module, []).extend(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("nao_arena"):
                    out.setdefault(a.name, [])
    return out


def test_results_and_table_do_not_depend_on_running() -> None:
    """The results files and the table are built from result records alone: neither
    imports the runner, the arena or the agents directly; no part imports another's
    private names."""
    import importlib

    parts = ["config", "episode", "run", "results", "table"]
    imports = {p: _nao_imports(importlib.import_module(f"nao_arena.trials.{p}")) for p in parts}
    for part in ("results", "table"):
        assert not {"nao_arena.trials.run", "nao_arena.arena", "nao_arena.agent"} & set(
            imports[part]
        ), part
    assert imports["table"] == {}
    for part, found in imports.items():
        private = [n for names in found.values() for n in names if n.startswith("_")]
        assert not private, f"trials/{part}.py imports {private}"
