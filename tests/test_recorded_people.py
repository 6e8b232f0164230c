"""Recorded people as traffic (``traffic: [{type: recorded, ...}]``): replayed at every
control step as the recording says, absent before they appear and after they leave,
pushed by nothing and pushing nothing (their contacts counted, not resolved), their
own contacts among themselves not counted; checked against the recording read
independently (:mod:`nao_arena.pedestrians`) and, where ../shared is present, on the real
ETH and UCY recordings."""

from __future__ import annotations

import copy
import pickle
from pathlib import Path

import numpy as np
import pytest

from nao_arena.arena import Arena
from nao_arena.maps import MapError, load_map, map_from_dict, with_time_limit
from nao_arena.pedestrians import read_recording
from nao_arena.world import World

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "pedestrians"
REAL_RECORDINGS = [("eth_univ", 15.0), ("eth_hotel", 25.0), ("ucy_zara01", 25.0)]
"""The shared recordings' folders and their frames per second."""

# frame id x y at 10 fps: person 1 walks +x from t = 0 to 4 s; person 2 appears at 1 s
# and leaves at 2.5 s; person 3 walks -x along y = 0.2 (towards person 1), 0 .. 4 s
TRACKS = [
    *[(f, 1, -3.0 + 0.15 * f, 0.0) for f in range(0, 41)],
    *[(f, 2, 2.0, 3.0 - 0.1 * (f - 10)) for f in range(10, 26)],
    *[(f, 3, 3.0 - 0.15 * f, 0.2) for f in range(0, 41)],
]


def _write_tracks(folder: Path) -> Path:
    path = folder / "walk.txt"
    path.write_text("\n".join(f"{f} {i} {x!r} {y!r}" for f, i, x, y in TRACKS) + "\n")
    return path


def _map(file: str, robots: list | None = None, **recorded) -> dict:
    return {
        "name": "recorded",
        "bounds": {"min": [-6, -6], "max": [6, 6]},
        "robots": robots
        if robots is not None
        else [{"name": "r", "start": [0.0, -5.0], "goal": [0.0, -5.0], "agent": "goal"}],
        "traffic": [{"type": "recorded", "file": file, "format": "xy", "fps": 10.0, **recorded}],
        "episode": {"time_limit": 4.0},
    }


@pytest.fixture
def tracks(tmp_path) -> Path:
    return _write_tracks(tmp_path)


def test_people_follow_the_recording_at_every_control_step(tracks):
    spec = map_from_dict(_map(str(tracks), time_offset=0.5, name="p"))
    rec = read_recording(tracks, "xy", fps=10.0, time_offset=0.5)
    assert [b.name for b in spec.bodies()] == ["r", "p1", "p2", "p3"]
    assert [b.kind for b in spec.bodies()] == ["robot", "person", "person", "person"]
    world = World(spec)
    state = world.state()
    for step in range(30):
        t = world.time
        truth, _ = rec.states(t)
        after, _ = rec.states(t + world.dt)
        for k in range(3):
            here = np.all(np.isfinite(truth[k])) and np.all(np.isfinite(after[k]))
            body = 1 + k
            if here:
                np.testing.assert_allclose(state.positions[body], truth[k], atol=1e-12)
                np.testing.assert_allclose(
                    state.velocities[body], (after[k] - truth[k]) / world.dt, atol=1e-9
                )
            else:  # waiting far away, still
                assert np.all(state.positions[body] < -900.0)
                assert np.all(state.velocities[body] == 0.0)
        state = world.step(np.zeros((4, 2)))
        assert step >= 0


def test_people_appear_and_leave_at_whole_control_periods(tracks):
    world = World(map_from_dict(_map(str(tracks))))
    seen = []
    for _ in range(39):
        seen.append(world.state().positions[2, 0] > -900.0)
        world.step(np.zeros((4, 2)))
    # person 2 is annotated from 1.0 s to 2.5 s: in the scene for the periods within it
    times = 0.1 * np.arange(39)
    expected = (times >= 1.0 - 1e-9) & (times + 0.1 <= 2.5 + 1e-9)
    assert seen == expected.tolist()


def test_recorded_people_and_robots_meet_without_pushing(tracks):
    """The robot holds its place on the people's way: they walk through it, the contacts
    are counted, and neither moves the other (a recording cannot react, and it does not
    shove what it meets as an infinite mass would)."""
    robots = [{"name": "r", "start": [0.0, 0.1], "goal": [0.0, 0.1], "agent": "goal"}]
    met = Arena(map_from_dict(_map(str(tracks), robots=robots)))
    alone = Arena(map_from_dict(_map(str(tracks))))
    met.reset(0)
    alone.reset(0)
    touched = 0
    for _ in range(39):
        a, b = met.step(), alone.step()
        touched += len(a.contacts)
        np.testing.assert_array_equal(a.state.positions[1:], b.state.positions[1:])
        np.testing.assert_array_equal(a.state.positions[0], [0.0, 0.1])
        np.testing.assert_array_equal(a.state.velocities[0], [0.0, 0.0])
    assert touched >= 1


def test_contacts_among_recorded_people_are_not_counted(tracks):
    # persons 1 and 3 walk into each other (0.2 m apart sideways, radius 0.3)
    summary = Arena(map_from_dict(_map(str(tracks)))).run(0)
    assert not [c for c in summary.contacts if c.kind_a == c.kind_b == "person"]
    (robot,) = summary.robots
    assert robot.among_people and robot.person_contacts == 0


def test_people_waiting_to_appear_are_never_sensed(tracks):
    arena = Arena(map_from_dict(_map(str(tracks))))
    arena.reset(0)
    for _ in range(39):
        obs = arena.observations()[0]
        positions = arena.state.positions
        for body in obs.neighbours.ids:
            assert positions[body, 0] > -900.0
        arena.step()


def test_copies_continue_bit_for_bit(tracks):
    robots = [{"name": "r", "start": [0.0, 1.0], "goal": [0.0, -1.0], "agent": "goal"}]
    world = World(map_from_dict(_map(str(tracks), robots=robots)))
    for _ in range(12):
        world.step(np.array([[0.0, -1.0], [0, 0], [0, 0], [0, 0]]))
    twins = [copy.deepcopy(world), pickle.loads(pickle.dumps(world))]
    for _ in range(20):
        command = np.array([[0.5, -1.0], [0, 0], [0, 0], [0, 0]])
        a = world.step(command)
        for twin in twins:
            b = twin.step(command)
            np.testing.assert_array_equal(a.positions, b.positions)
            np.testing.assert_array_equal(a.velocities, b.velocities)


def test_a_relative_file_is_relative_to_the_map_file(tmp_path, tracks):
    (tmp_path / "scene.yaml").write_text(
        "name: scene\nbounds: {min: [-6, -6], max: [6, 6]}\n"
        "robots: [{start: [0, -5], goal: [0, -5]}]\n"
        "traffic: [{type: recorded, file: walk.txt, format: xy, fps: 10}]\n"
        "episode: {time_limit: 4}\n"
    )
    spec = load_map(tmp_path / "scene.yaml")
    assert spec.n_recorded == 3 and spec.recorded[0].file == str(tracks)


def test_bad_recorded_entries_are_one_line_map_errors(tmp_path, tracks):
    with pytest.raises(MapError, match=r"traffic\[0\]\.file: .*missing.txt: no such"):
        map_from_dict(_map(str(tmp_path / "missing.txt")))
    with pytest.raises(MapError, match=r"traffic\[0\]\.fps: expected a positive number"):
        map_from_dict(_map(str(tracks), fps=0))
    with pytest.raises(MapError, match=r"traffic\[0\]\.format: "):
        map_from_dict(_map(str(tracks), format="csv"))
    bad = tmp_path / "bad.txt"
    bad.write_text("0 1 x 0\n")
    with pytest.raises(MapError, match=r"traffic\[0\]\.file: .*bad.txt: line 1"):
        map_from_dict(_map(str(bad)))
    with pytest.raises(MapError) as info:
        map_from_dict(_map(str(tmp_path / "missing.txt")))
    assert "\n" not in str(info.value)


def test_a_longer_time_limit_replays_the_people_it_reaches(tracks):
    spec = map_from_dict({**_map(str(tracks)), "episode": {"time_limit": 0.5}})
    assert spec.n_recorded == 2  # person 2 appears at 1 s
    assert with_time_limit(spec, 4.0).n_recorded == 3


@pytest.mark.parametrize(("folder", "fps"), REAL_RECORDINGS)
def test_real_recordings_replay_and_a_robot_crosses_them(folder, fps):
    source = SHARED / folder / "obsmat.txt"
    if not source.is_file():
        pytest.skip(f"{source} is absent (the shared pedestrian data: see its README)")
    rec = read_recording(source, "obsmat", fps=fps, time_offset=120.0)
    lo, hi = rec.positions.min(axis=0) - 1.0, rec.positions.max(axis=0) + 1.0
    data = {
        "name": folder,
        "bounds": {"min": lo.tolist(), "max": hi.tolist()},
        "robots": [
            {
                "name": "robot",
                "start": (lo + 1.0).tolist(),
                "goal": (hi - 1.0).tolist(),
                "v_max": 1.0,
                "predictor": "constant_velocity",
            }
        ],
        "traffic": [{"type": "recorded", "file": str(source), "fps": fps, "time_offset": 120.0}],
        "episode": {"time_limit": 20.0},
    }
    arena = Arena(map_from_dict(data))
    arena.reset(0)
    for _ in range(50):
        state = arena.step().state
    people = state.positions[1:]
    here = people[:, 0] > -900.0
    truth, _ = rec.states(arena.state.time)
    chosen = arena.spec.recorded[0].people
    np.testing.assert_allclose(people[here], truth[chosen][here], atol=1e-9)
    assert here.any()


CROSSING_MAPS = Path(__file__).resolve().parents[1] / "benchmarks" / "people"


@pytest.mark.parametrize(("folder", "fps"), REAL_RECORDINGS)
def test_the_crossing_maps_cross_where_the_recording_sees_people(folder, fps):
    """The robot of each shipped crossing map starts and ends inside the area the
    recording annotates (its people's bounding box), at least a robot radius within it,
    whatever the seed: outside it nobody is recorded, and people walk in out of nowhere."""
    source = SHARED / folder / "obsmat.txt"
    if not source.is_file():
        pytest.skip(f"{source} is absent (the shared pedestrian data: see its README)")
    positions = read_recording(source, "obsmat", fps=fps).positions
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    for seed in range(60):
        spec = load_map(str(CROSSING_MAPS / f"{folder}.yaml"), seed=seed, robot_v_max=1.5)
        (robot,) = spec.robots
        assert robot.v_max == 1.5
        for point in (robot.start, robot.goal):
            assert np.all(np.asarray(point) >= lo + robot.radius), (seed, point, lo)
            assert np.all(np.asarray(point) <= hi - robot.radius), (seed, point, hi)


def test_a_person_appearing_on_a_moving_robot_is_not_the_robots_doing(tmp_path):
    # the robot drives along y = -5; a person appears right on it at t = 1 s
    path = tmp_path / "appear.txt"
    rows = [(f, 9, -0.6, -5.0) for f in range(10, 30)]  # the robot is at x = -0.70 at 1 s
    path.write_text("\n".join(f"{f} {i} {x} {y}" for f, i, x, y in rows) + "\n")
    robots = [{"name": "r", "start": [-1.0, -5.0], "goal": [5.0, -5.0], "agent": "goal"}]
    data = _map(str(path), robots=robots)
    data["robots"][0]["v_max"] = 0.5
    summary = Arena(map_from_dict(data)).run(0)
    (robot,) = summary.robots
    (contact,) = [c for c in summary.contacts if "person" in (c.kind_a, c.kind_b)]
    assert contact.began_overlapping and contact.speed_a > 0.4
    assert (robot.person_contacts, robot.caused_person_contacts) == (1, 0)


def _standing_tracks(folder: Path, where: tuple[float, float], until: int) -> Path:
    """At 10 fps: person 7 stands at ``where`` (m) from frame 0 to ``until``; person 8
    walks far away for 10 s (the recording's span)."""
    rows = [(f, 7, *where) for f in range(0, until + 1)]
    rows += [(f, 8, 5.0, -5.0 + 0.05 * f) for f in range(0, 101)]
    path = folder / "standing.txt"
    path.write_text("\n".join(f"{f} {i} {x} {y}" for f, i, x, y in rows) + "\n")
    return path


def _start_time(data: dict, seed: int) -> float:
    return map_from_dict(data, rng=np.random.default_rng(seed)).recorded[0].time_offset


def test_no_robot_starts_on_a_recorded_person(tmp_path):
    """Person 7 stands on the robot's start for the first 2 s of the recording: a start
    time that has them in the scene for the first control period (0.1 s) is drawn again;
    a first draw without them is kept as it was."""
    robots = [{"name": "r", "start": [0.0, 0.0], "goal": [0.0, 0.0], "agent": "goal"}]
    data = _map(str(_standing_tracks(tmp_path, (0.0, 0.0), 20)), robots=robots, time_jitter=4.0)
    redrawn = 0
    for seed in range(12):
        first = float(np.random.default_rng(seed).uniform(0.0, 4.0))
        start = _start_time(data, seed)
        assert start > 1.9
        if first > 1.9:
            assert start == first
        else:
            redrawn += 1
    assert redrawn > 0
    # without a time_jitter the start time is the map's, whoever stands there
    fixed = _map(str(_standing_tracks(tmp_path, (0.0, 0.0), 20)), robots=robots)
    assert _start_time(fixed, 0) == 0.0


def test_start_clearance_keeps_recorded_people_away_from_the_robots_starts(tmp_path):
    robots = [
        {"name": "r", "start": [0.0, 0.0], "goal": [0.0, 0.0], "agent": "goal", "radius": 0.3}
    ]
    # person 7 stands 1.2 m from the robot's start: 0.6 m between the two discs
    path = _standing_tracks(tmp_path, (1.2, 0.0), 20)
    near = [s for s in range(12) if float(np.random.default_rng(s).uniform(0.0, 4.0)) <= 1.9]
    for seed in near:
        assert _start_time(_map(str(path), robots=robots, time_jitter=4.0), seed) <= 1.9
        kept = _map(str(path), robots=robots, time_jitter=4.0, start_clearance=1.0)
        assert _start_time(kept, seed) > 1.9
    assert near


def _walking_in_tracks(folder: Path) -> Path:
    """At 10 fps: person 7 walks along y = 0 from x = 3 m at -1 m/s for 6 s, through the
    origin at 3 s (the recording's only person besides person 8, far away)."""
    rows = [(f, 7, 3.0 - 0.1 * f, 0.0) for f in range(0, 61)]
    rows += [(f, 8, 5.0, -5.0 + 0.05 * f) for f in range(0, 101)]
    path = folder / "walking.txt"
    path.write_text("\n".join(f"{f} {i} {x} {y}" for f, i, x, y in rows) + "\n")
    return path


def test_start_clearance_for_keeps_people_about_to_walk_into_a_start_away(tmp_path):
    """Person 7 walks through the robot's start (the origin) 3 s into the recording. At a
    start time of 2.5 s they are 0.5 m from it (0.1 m surface to surface), and clear of
    it at the start itself with start_clearance 0; with start_clearance_for 1 s, every
    start time at which they come within the clearance in the next second is drawn again."""
    robots = [
        {"name": "r", "start": [0.0, 0.0], "goal": [0.0, 0.0], "agent": "goal", "radius": 0.2}
    ]
    path = _walking_in_tracks(tmp_path)
    reach = 0.2 + 0.3 + 0.5  # radii and the clearance (m): at x = 3 - t, in reach for t in (2, 4)
    kept = redrawn = 0
    for seed in range(40):
        first = float(np.random.default_rng(seed).uniform(0.0, 6.0))
        plain = _start_time(
            _map(str(path), robots=robots, time_jitter=6.0, start_clearance=0.5), seed
        )
        ahead = _start_time(
            _map(
                str(path),
                robots=robots,
                time_jitter=6.0,
                start_clearance=0.5,
                start_clearance_for=1.0,
            ),
            seed,
        )
        # at the kept start time, the person stays out of reach for a second (or is gone)
        assert min(abs(3.0 - ahead - 0.1 * k) for k in range(11)) >= reach - 1e-9
        if 1.05 < first < 1.95:  # out of reach at the start, within reach in a second
            assert plain == first
            assert ahead != first
            redrawn += 1
        elif first < 0.95 or first > 4.05:  # out of reach for the whole second
            assert ahead == plain == first
            kept += 1
    assert redrawn > 0 and kept > 0


def test_a_start_that_no_draw_clears_is_a_one_line_map_error(tmp_path):
    robots = [{"name": "r", "start": [0.0, 0.0], "goal": [0.0, 0.0], "agent": "goal"}]
    data = _map(str(_standing_tracks(tmp_path, (0.0, 0.0), 100)), robots=robots, time_jitter=4.0)
    with pytest.raises(MapError, match=r"traffic\[0\]\.start_clearance: expected a start time"):
        map_from_dict(data)


def test_the_known_path_oracle_reads_the_recording(tracks):
    spec = map_from_dict(_map(str(tracks)))
    rec = read_recording(tracks, "xy", fps=10.0)
    arena = Arena(spec)
    arena.reset(0)
    for _ in range(12):
        arena.step()
    batch = arena.sensing()
    t = arena.state.time
    for k in range(3):
        body = 1 + k
        path = batch.known_paths[body]
        if arena.state.positions[body, 0] < -900.0:  # waiting: nothing is known
            assert np.all(np.isnan(path))
            continue
        want = rec.path(k, t + batch.path_times)
        ended = np.isnan(want[:, 0])
        np.testing.assert_allclose(path[~ended], want[~ended], atol=1e-12)
        # after its last annotation a person's known path stays where it left
        last = rec.positions[rec.offsets[k + 1] - 1]
        np.testing.assert_allclose(path[ended], np.broadcast_to(last, path[ended].shape))


def test_start_clearance_for_is_bounded(tmp_path):
    """Each draw checks every control step of start_clearance_for: a map cannot ask for
    days of them (a hang), it gets a one-line error."""
    path = _walking_in_tracks(tmp_path)
    data = _map(str(path), time_jitter=6.0, start_clearance=0.5, start_clearance_for=61.0)
    with pytest.raises(
        MapError, match=r"traffic\[0\]\.start_clearance_for: expected a number <= 60"
    ):
        map_from_dict(data)
