"""Episode logs: recording changes nothing, the round trip is bit for bit, the decisions
and predictions are the agents' own, bad files are one-line errors, trials log."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena import _log_schema, _log_write, episode_log
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.cli import main
from nao_arena.episode_log import (
    LOG_VERSION,
    STATUSES,
    EpisodeRecorder,
    LogError,
    read_log,
    write_log,
)
from nao_arena.maps import load_map, map_from_dict
from nao_arena.report import contact_logs, report_text
from nao_arena.trials import TrialConfig, make_map, run_trial

ARRAYS = (
    "time",
    "positions",
    "velocities",
    "accelerations",
    "commanded",
    "reached",
    "status",
    "selection",
    "detour",
    "nb_offsets",
    "nb_index",
    "nb_logged",
    "contact_steps",
    "fault_steps",
)


def logged(
    map_name: str,
    seed: int,
    params: dict,
    max_steps: int | None = None,
    options: ArenaOptions | None = None,
) -> tuple[Arena, episode_log.EpisodeLog]:
    arena = Arena(make_map(map_name, seed, params), options)
    arena.recorder = EpisodeRecorder(context={"map": map_name})
    arena.run(seed, max_steps=max_steps)
    return arena, arena.recorder.finish()


def robot_rows(log: episode_log.EpisodeLog) -> list[tuple]:
    return [
        (
            r.name,
            r.body,
            r.agent,
            r.label,
            r.predictor,
            r.margin,
            r.v_pref,
            None if r.times is None else r.times.tobytes(),
        )
        for r in log.robots
    ]


@pytest.fixture(scope="module")
def goal_log(tmp_path_factory) -> Path:
    """Two goal seekers on a 1 m circle: they touch at t = 0.91 s."""
    _, log = logged("circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, max_steps=30)
    return write_log(log, tmp_path_factory.mktemp("logs") / "goal.parquet")


class Faulty:
    """Goal seeking that raises at 0.5 s <= t < 0.7 s."""

    def reset(self, spec, rng):
        pass

    def act(self, obs):
        if 0.5 <= obs.time < 0.7:
            raise RuntimeError("boom")
        to_goal = obs.goal - obs.position
        return np.clip(to_goal - obs.velocity, -1.0, 1.0)


@pytest.mark.parametrize(
    "case",
    [
        ("circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 30),  # a contact
        ("roundabout", 3, {}, 25),  # nao robots, traffic
        ("circle_swap", 1, {"n": 5}, 40),  # nao crowd
    ],
)
def test_recording_changes_nothing_and_the_round_trip_is_bit_for_bit(case, tmp_path):
    map_name, seed, params, steps = case
    plain = Arena(make_map(map_name, seed, params)).run(seed, max_steps=steps)
    arena, log = logged(map_name, seed, params, max_steps=steps)
    assert arena.summary().to_dict() == plain.to_dict()  # same trajectory, same statistics
    assert log.n_steps == plain.steps + 1 and log.trajectory_hash() == plain.trajectory_hash
    path = write_log(log, tmp_path / "episode.parquet")
    back = read_log(path)
    for name in ARRAYS:
        a, b = getattr(log, name), getattr(back, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert a.tobytes() == b.tobytes(), name
    assert back.spec == arena.spec and back.seed == seed and back.run == {"map": map_name}
    assert back.summary == plain.to_dict() and back.options == log.options
    assert robot_rows(back) == robot_rows(log)
    assert [c.to_dict() for c in back.contacts] == plain.to_dict()["contacts"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["episode.parquet"]  # no temporary


def test_statuses_follow_the_decisions():
    arena, log = logged("circle_swap", 2, {"n": 6}, max_steps=80)
    codes = {s: i for i, s in enumerate(STATUSES)}
    body = log.robot_ids
    cmd = log.commanded[:, body]
    assert np.all(log.status[0] == -1) and np.all(log.status[1:] >= 0)
    seen = set(np.unique(log.status[1:]).tolist())
    assert {codes["desired"], codes["kept"], codes["adjusted"]} <= seen, seen
    # kept: the same acceleration as the step before; repaired and full selections: a new
    # one, or the same desired one again
    kept = log.status[2:] == codes["kept"]
    same = np.all(cmd[2:] == cmd[1:-1], axis=-1)
    assert np.all(same[kept])
    repaired = log.status[2:] == codes["repaired"]
    assert not np.any(same[repaired])
    # a full selection is what the agent reports as its last one
    full = np.isin(log.status, [codes["desired"], codes["adjusted"], codes["infeasible"]])
    for s, k in zip(*np.nonzero(full), strict=True):
        assert STATUSES[log.status[s, k]] == log.selection_of(s, k)
    # the NAO agents' detours and neighbours are logged, their predictor too
    assert all(r.predictor == "turn_rate" and r.times is not None for r in log.robots)
    assert np.all(np.isfinite(log.detour)) and np.all(log.nb_logged)
    # the goal seeker's commands are its desired ones
    _, goal = logged("circle_swap", 0, {"n": 3, "agent": "goal"}, max_steps=20)
    assert np.all(goal.status[1:] == codes["desired"])
    assert not goal.nb_logged.any() and np.all(np.isnan(goal.detour))


def test_mixed_agents_log_neighbours_of_the_predicting_robots_only(tmp_path):
    spec = map_from_dict(
        {
            "name": "mixed",
            "bounds": {"min": [-6, -6], "max": [6, 6]},
            "robots": [
                {"name": "a", "start": [-4, 0], "goal": [4, 0], "agent": "nao"},
                {"name": "b", "start": [4, 0.2], "goal": [-4, 0], "agent": "goal"},
                {"name": "c", "start": [0, -4], "goal": [0, 4], "agent": "ao"},
            ],
        }
    )
    arena = Arena(spec)
    arena.recorder = EpisodeRecorder()
    arena.run(0, max_steps=40)
    log = arena.recorder.finish()
    assert log.nb_logged.tolist() == [True, False, True]
    assert [r.predictor for r in log.robots] == ["turn_rate", None, "constant_acceleration"]
    assert log.neighbours(5, 1) is None and sorted(log.neighbours(5, 0).tolist()) == [1, 2]
    back = read_log(write_log(log, tmp_path / "mixed.parquet"))
    for name in ARRAYS:
        assert getattr(back, name).tobytes() == getattr(log, name).tobytes(), name
    for step in (1, 20, 40):
        for k in (0, 2):
            assert np.array_equal(back.neighbours(step, k), log.neighbours(step, k))
    table = pq.read_table(tmp_path / "mixed.parquet")
    nb = table.column("neighbours").to_pylist()
    assert all(v is None for v in nb[:3])  # row 0
    assert nb[3 + 1] is None and nb[3] is not None and nb[3 + 2] is not None


def test_faults_and_external_actions_have_their_status():
    spec = load_map("circle_swap", n=3, radius=2.0)
    arena = Arena(spec, ArenaOptions(agent=f"{__file__}:Faulty"))
    arena.recorder = EpisodeRecorder()
    arena.reset(0)
    for step in range(10):
        arena.step({2: np.zeros(2)} if step == 3 else None)
    log = arena.recorder.finish()
    codes = {s: i for i, s in enumerate(STATUSES)}
    assert log.status_of(4, 2) == "external" and log.status_of(4, 0) == "adjusted"
    faulty = [s for s in range(1, 11) if log.status_of(s, 0) == "fault"]
    assert faulty == [6, 7]  # decided at t = 0.5 and 0.6 s
    assert log.fault_steps.tolist() == [6, 6, 6, 7, 7, 7]
    assert np.all(log.commanded[6:8, :3] == 0.0)
    assert codes["fault"] in log.status


def test_decision_inputs_are_what_the_agent_sensed_and_predicted():
    spec = make_map("roundabout", 3, {"predictor": "turn_rate"})
    arena = Arena(spec)
    arena.recorder = EpisodeRecorder()
    arena.reset(3)
    live = []
    for _ in range(15):
        batch = arena.sensing()
        obs = [batch.observation(k) for k in range(len(arena.robots))]
        pred = [ag.predict(ag.times, o.neighbours) for ag, o in zip(arena.agents, obs, strict=True)]
        live.append((obs, pred))
        arena.step()
    log = arena.recorder.finish()
    for step, (obs, pred) in enumerate(live, start=1):
        for k in range(len(arena.robots)):
            inputs = log.decision_inputs(step, k)
            nb = inputs.observation.neighbours
            assert np.array_equal(log.neighbours(step, k), obs[k].neighbours.ids)
            assert nb.ids.tolist() == obs[k].neighbours.ids.tolist()
            for field in ("positions", "velocities", "accelerations", "plans", "known_paths"):
                a, b = getattr(nb, field), getattr(obs[k].neighbours, field)
                assert (a is None and b is None) or a.tobytes() == b.tobytes(), field
            assert inputs.predicted.tobytes() == pred[k].tobytes()


# --------------------------------------------------------------------------- bad files


def _one_line_error(excinfo, path: Path) -> str:
    message = str(excinfo.value)
    assert "\n" not in message and message.startswith(str(path))
    return message


@settings(max_examples=25, deadline=None)
@given(cut=st.floats(0.0, 0.999))
def test_a_truncated_log_is_a_clear_error(goal_log, tmp_path_factory, cut):
    data = goal_log.read_bytes()
    path = tmp_path_factory.mktemp("cut") / "cut.parquet"
    path.write_bytes(data[: int(cut * len(data))])
    with pytest.raises(LogError) as excinfo:
        read_log(path)
    assert "truncated" in _one_line_error(excinfo, path)


@settings(max_examples=60, deadline=None)
@given(where=st.floats(0.0, 0.9999), bit=st.integers(0, 7))
def test_a_flipped_bit_is_found_or_changes_nothing(goal_log, tmp_path_factory, where, bit):
    """Page checksums cover the data, a SHA-256 the metadata and the trajectory hash the
    states: a flipped bit is a clear error, or lies where nothing that is read changes
    (the file's leading magic, statistics, pyarrow's copy of the schema)."""
    original = read_log(goal_log)
    data = bytearray(goal_log.read_bytes())
    data[int(where * len(data))] ^= 1 << bit
    path = tmp_path_factory.mktemp("flip") / "flip.parquet"
    path.write_bytes(bytes(data))
    try:
        back = read_log(path)
    except LogError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path))
        return
    for name in ARRAYS:
        assert getattr(back, name).tobytes() == getattr(original, name).tobytes(), name
    assert back.summary == original.summary and back.spec == original.spec
    assert robot_rows(back) == robot_rows(original)


def test_corrupt_and_foreign_files_are_clear_errors(goal_log, tmp_path):
    data = bytearray(goal_log.read_bytes())
    cases = {}
    # bytes overwritten in a data page (its checksum fails)
    broken = bytearray(data)
    start = pq.ParquetFile(goal_log).metadata.row_group(0).column(3).data_page_offset
    broken[start + 40 : start + 88] = bytes(48)
    cases["zeroed.parquet"] = (bytes(broken), "corrupt")
    cases["noise.parquet"] = (os.urandom(5000), "truncated, or not a Parquet file")
    cases["empty.parquet"] = (b"", "truncated")
    for name, (content, expect) in cases.items():
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(LogError) as excinfo:
            read_log(path)
        assert expect in _one_line_error(excinfo, path), name
    # a Parquet file that is not a log
    other = tmp_path / "other.parquet"
    pq.write_table(pq.read_table(goal_log).select(["x", "y"]).replace_schema_metadata({}), other)
    with pytest.raises(LogError, match="not an episode log"):
        read_log(other)
    with pytest.raises(LogError, match="no such file"):
        read_log(tmp_path / "missing.parquet")


def _rewrite(
    src: Path, dst: Path, meta_edit=None, table_edit=None, fix_sha=True, fix_rows=True
) -> Path:
    """A copy of the log ``src`` with its metadata or rows edited, and (a forger's work)
    the metadata's checksum and the rows' digest made to match unless told not to."""
    from nao_arena._log_schema import CONTENT_KEY, table_digest

    table = pq.read_table(src)
    kv = {k: v for k, v in pq.ParquetFile(src).metadata.metadata.items() if k != b"ARROW:schema"}
    meta = json.loads(kv[episode_log.META_KEY])
    if meta_edit:
        meta_edit(meta)
    if table_edit:
        table = table_edit(table)
        if fix_rows:
            meta[CONTENT_KEY] = table_digest(table)
    raw = json.dumps(meta).encode()
    kv[episode_log.META_KEY] = raw
    if fix_sha:
        import hashlib

        kv[episode_log.META_SHA_KEY] = hashlib.sha256(raw).hexdigest().encode()
    pq.write_table(table.replace_schema_metadata(kv), dst)
    return dst


def test_other_versions_and_tampered_logs_are_refused(goal_log, tmp_path):
    path = _rewrite(goal_log, tmp_path / "v99.parquet", lambda m: m.update(version=99))
    with pytest.raises(LogError) as excinfo:
        read_log(path)
    message = _one_line_error(excinfo, path)
    assert "version 99" in message and f"reads version {LOG_VERSION}" in message
    path = _rewrite(goal_log, tmp_path / "meta.parquet", lambda m: m.update(seed=1), fix_sha=False)
    with pytest.raises(LogError, match="checksum"):
        read_log(path)

    def moved(table):
        import pyarrow as pa

        x = table.column("x").to_numpy().copy()
        x[7] += 1e-12
        return table.set_column(table.column_names.index("x"), "x", pa.array(x))

    path = _rewrite(goal_log, tmp_path / "moved.parquet", table_edit=moved, fix_rows=False)
    with pytest.raises(LogError, match="rows do not match their checksum"):
        read_log(path)
    path = _rewrite(goal_log, tmp_path / "moved.parquet", table_edit=moved)
    with pytest.raises(LogError, match="trajectory hash"):
        read_log(path)
    path = _rewrite(goal_log, tmp_path / "rows.parquet", table_edit=lambda t: t.slice(0, 10))
    with pytest.raises(LogError, match="rows"):
        read_log(path)


@pytest.mark.parametrize("edit", ["cut", "swapped", "summary"])
def test_a_log_whose_robot_list_does_not_match_its_map_is_refused(goal_log, tmp_path, capsys, edit):
    """A cut robot list made replay fail with IndexError, and explain accept the log."""
    from nao_arena.cli import main

    def change(meta):
        if edit == "cut":
            meta["robots"] = meta["robots"][:-1]
        elif edit == "swapped":
            meta["robots"][0]["body"], meta["robots"][1]["body"] = 1, 0
        else:
            meta["summary"]["robots"] = meta["summary"]["robots"][:1]

    path = _rewrite(goal_log, tmp_path / f"{edit}.parquet", change)
    with pytest.raises(LogError) as excinfo:
        read_log(path)
    assert "corrupt episode log" in _one_line_error(excinfo, path)
    for command in (
        ["replay", str(path), "--at", "1", "--png", str(tmp_path / "f.png")],
        ["explain", str(path)],
    ):
        assert main(command) == 2, command
        err = capsys.readouterr().err.strip()
        assert err.startswith("nao-arena: error: ") and "\n" not in err
        assert "corrupt episode log" in err


def test_a_failed_write_leaves_the_old_log(goal_log, tmp_path, monkeypatch):
    target = tmp_path / "keep.parquet"
    target.write_bytes(b"old")
    log = read_log(goal_log)

    class Failing(pq.ParquetWriter):
        def write_table(self, *args, **kwargs):
            super().write_table(*args, **kwargs)
            raise OSError("disk full")

    monkeypatch.setattr(_log_write.pq, "ParquetWriter", Failing)
    with pytest.raises(OSError):
        write_log(log, target)
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.parquet"]


def test_cli_reports_bad_logs_in_one_line(goal_log, tmp_path, capsys):
    cut = tmp_path / "cut.parquet"
    cut.write_bytes(goal_log.read_bytes()[:-100])
    for argv in (
        ["replay", str(cut), "--at", "0", "--png", str(tmp_path / "f.png")],
        ["explain", str(cut), "--contact", "1"],
        ["explain", str(tmp_path / "none.parquet")],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("nao-arena: error: ") and err.count("\n") == 1, err
        assert "Traceback" not in err
    assert not (tmp_path / "f.png").exists()


# --------------------------------------------------------------------------- run, trial


def test_run_log_holds_the_episode(tmp_path, capsys):
    log_path, json_path = tmp_path / "run.parquet", tmp_path / "run.json"
    assert (
        main(
            [
                "run",
                "circle_swap",
                "--set",
                "n=3",
                "--seed",
                "2",
                "--max-steps",
                "25",
                "--log",
                str(log_path),
                "--json",
                str(json_path),
            ]
        )
        == 0
    )
    assert f"wrote {log_path}" in capsys.readouterr().out
    log = read_log(log_path)
    assert log.summary == json.loads(json_path.read_text())
    assert log.n_steps == 26 and log.seed == 2
    assert log.run["map"] == "circle_swap" and log.run["overrides"] == {"n": 3}
    assert log.spec == make_map("circle_swap", 2, {"n": 3})


def test_trial_logs_the_episodes_with_contacts_and_names_them(tmp_path):
    config = TrialConfig(
        maps=("circle_swap_perturbed",),
        agents=("goal", "nao"),
        episodes=1,
        seed=7,
        out=tmp_path,
        overrides={"n": 4},
        time_limit=15.0,
        log="contacts",
    )
    first = run_trial(config, progress=None)
    logs = sorted(p.name for p in (tmp_path / "logs").iterdir())
    assert logs == ["circle_swap_perturbed__goal__00000.parquet"]  # nao: no contact
    rows = pq.read_table(tmp_path / "collisions.parquet").to_pylist()
    assert rows and {r["log"] for r in rows} == {f"logs/{logs[0]}"}
    assert [r["contact"] for r in rows] == list(range(1, len(rows) + 1))
    log = read_log(tmp_path / rows[0]["log"])
    for r in rows:  # each row is the log's contact of that number
        c = log.contacts[r["contact"] - 1]
        assert (c.time, c.name_a, c.name_b) == (r["time"], r["name_a"], r["name_b"])
    assert log.run["episode"] == 0 and log.run["agent"] == "goal"
    listed = contact_logs(tmp_path)
    assert [(e["agent"], e["contacts"], e["log"]) for e in listed] == [
        ("goal", len(rows), str(tmp_path / "logs" / logs[0]))
    ]
    assert str(tmp_path / "logs" / logs[0]) in report_text(tmp_path)
    # every episode now: the one without a log runs again, with the same results
    again = run_trial(TrialConfig(**{**config.__dict__, "log": "all"}), progress=None)
    assert again.ran == 1 and again.summary == first.summary
    assert len(list((tmp_path / "logs").iterdir())) == 2
    with pytest.raises(ValueError, match="log: expected one of all, contacts"):
        TrialConfig(maps=("crowd",), agents=("nao",), log="some")


def test_the_readme_documents_every_column_and_status():
    # the page the README's "The log format" moved to
    page = Path(__file__).resolve().parents[1] / "docs" / "reference" / "episode-log.md"
    section = page.read_text(encoding="utf-8")
    for name in _log_schema._SCHEMA.names:
        assert f"`{name}`" in section, name
    for status in STATUSES:
        assert f"`{status}`" in section, status
    assert f"(version {LOG_VERSION})" in section


@pytest.mark.slow
def test_every_flip_in_page_headers_and_the_footer_is_found_or_changes_nothing(goal_log, tmp_path):
    """The page checksums do not cover the page headers or the footer's column metadata:
    the rows' own digest does. Every bit of every page header (its first 24 bytes) and of
    every 5th byte of the footer, flipped: a clear error, or nothing read changes."""
    original = read_log(goal_log)
    data = goal_log.read_bytes()
    meta = pq.ParquetFile(goal_log).metadata.row_group(0)
    offsets: set[int] = set()
    for i in range(meta.num_columns):
        column = meta.column(i)
        for start in (column.dictionary_page_offset, column.data_page_offset):
            if start is not None:
                offsets.update(range(start, min(start + 24, len(data))))
    footer = int.from_bytes(data[-8:-4], "little")
    offsets.update(range(len(data) - 8 - footer, len(data) - 8, 5))
    path = tmp_path / "flip.parquet"
    unnoticed = []
    for where in sorted(offsets):
        for bit in range(8):
            flipped = bytearray(data)
            flipped[where] ^= 1 << bit
            path.write_bytes(bytes(flipped))
            try:
                back = read_log(path)
            except LogError as exc:
                assert "\n" not in str(exc) and str(exc).startswith(str(path))
                continue
            changed = [
                n for n in ARRAYS if getattr(back, n).tobytes() != getattr(original, n).tobytes()
            ]
            if changed or back.summary != original.summary or back.spec != original.spec:
                unnoticed.append((where, bit, changed))
    assert not unnoticed, unnoticed[:5]
