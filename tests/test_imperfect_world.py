"""The imperfect world: sensing latency (agents act on what they sensed ``latency`` s ago),
sensing noise (Gaussian, per observer, neighbour and step), dropout (neighbours missed),
field of view (only bodies around the heading), actuation noise (Gaussian noise on the
robots' commands) and actuation lag (a first-order response to them), set in the map or
in :class:`~nao_arena.arena.ArenaOptions`; off by default (the golden episodes guard that).
Each model is measured against an independent computation here."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.imperfection import in_view, subset
from nao_arena.maps import MapError, load_map, map_from_dict


class Probe:
    """Records what it senses and returns a fixed push (m/s^2)."""

    seen: list[tuple[float, np.ndarray]]

    def reset(self, spec, rng):
        self.seen = []

    def act(self, obs):
        self.seen.append((obs.time, np.array(obs.position)))
        return np.array([0.5, 0.0])


def test_agents_act_on_what_they_sensed_latency_seconds_ago():
    spec = load_map("circle_swap", n=2)
    arena = Arena(spec, ArenaOptions(sensing_latency=0.3))
    arena.reset(0)
    probe = Probe()
    probe.reset(None, None)
    arena.agents = [probe, Probe()]
    arena.agents[1].reset(None, None)
    truth = [(arena.state.time, arena.state.positions[arena.robot_ids[0]].copy())]
    for _ in range(8):
        arena.step()
        truth.append((arena.state.time, arena.state.positions[arena.robot_ids[0]].copy()))
    dt = spec.physics.dt
    for step, (t, position) in enumerate(probe.seen):
        then = max(0, step - 3)  # 0.3 s = 3 control periods
        assert t == pytest.approx(truth[then][0]) and t == pytest.approx(then * dt)
        np.testing.assert_array_equal(position, truth[then][1])


def test_latency_rounds_to_whole_control_periods_and_comes_from_the_map():
    data = {
        "bounds": {"min": [-5, -5], "max": [5, 5]},
        "sensing": {"latency": 0.26},
        "robots": [{"start": [0, 0], "goal": [1, 0]}],
    }
    assert Arena(map_from_dict(data))._latency_steps == 3
    with pytest.raises(MapError, match="sensing.latency: expected a non-negative number"):
        map_from_dict({**data, "sensing": {"latency": -0.1}})
    with pytest.raises(ValueError, match="sensing_latency: expected a finite number >= 0"):
        Arena(map_from_dict(data), ArenaOptions(sensing_latency=float("nan")))


def test_actuation_noise_is_gaussian_on_the_commands_and_seeded():
    spec = load_map("circle_swap", n=4)
    sigma = 0.3
    arena = Arena(spec, ArenaOptions(agent="goal", actuation_noise=sigma))
    quiet = Arena(spec, ArenaOptions(agent="goal"))
    arena.reset(5)
    quiet.reset(5)
    # the same agents, fed the same state: the difference of the commands is the noise
    differences = []
    for _ in range(60):
        batch = arena.sensing()
        clean = np.array([a.act(batch.observation(k)) for k, a in enumerate(quiet.agents)])
        result = arena.step()
        differences.append(result.commanded[arena.robot_ids] - clean)
    noise = np.concatenate(differences)
    assert abs(noise.mean()) < 4 * sigma / np.sqrt(noise.size)
    assert noise.std() == pytest.approx(sigma, rel=0.15)
    # same seed, same episode; another seed, another one
    runs = [
        Arena(spec, ArenaOptions(agent="goal", actuation_noise=sigma)).run(s, max_steps=40)
        for s in (5, 5, 6)
    ]
    assert runs[0].trajectory_hash == runs[1].trajectory_hash != runs[2].trajectory_hash
    with pytest.raises(ValueError, match="actuation_noise"):
        Arena(spec, ArenaOptions(actuation_noise=-1.0))


# ------------------------------------------------------------------ sensing noise, dropout,
# field of view, actuation lag: each measured against an independent computation


class Seer:
    """Records every observation it gets and heads for its goal (its own state only)."""

    seen: list

    def reset(self, spec, rng):
        self.seen = []

    def act(self, obs):
        self.seen.append(obs)
        return np.clip(0.8 * (obs.goal - obs.position) - 1.5 * obs.velocity, -1.5, 1.5)


def _seers(arena, seed):
    """Reset ``arena`` with ``seed`` and give every robot a :class:`Seer`."""
    arena.reset(seed)
    arena.agents = [Seer() for _ in arena.robots]
    for a in arena.agents:
        a.reset(None, None)
    return arena.agents


def _run_seers(arena, seed, steps):
    """The seers' observations and the true states they were sensed from, step by step:
    [(truth (positions, velocities, accelerations), [observation of robot k])]."""
    seers = _seers(arena, seed)
    rows = []
    for _ in range(steps):
        s = arena.state
        truth = (s.positions.copy(), s.velocities.copy(), s.accelerations.copy())
        arena.step()
        rows.append((truth, [a.seen[-1] for a in seers]))
    return rows


def _lists(positions, bodies, reach, most=None, keep=None):
    """Brute-force neighbour lists: per observer body, the others within ``reach`` m by
    (distance, index), those where keep[observer row, body] holds, the first ``most``."""
    out = []
    for k, b in enumerate(bodies):
        rel = positions - positions[b]
        d = np.sqrt(rel[:, 0] * rel[:, 0] + rel[:, 1] * rel[:, 1])  # as the arena senses
        near = sorted((d[j], j) for j in range(len(positions)) if j != b and d[j] <= reach)
        ids = [j for _, j in near if keep is None or keep[k, j]]
        out.append(ids[:most] if most is not None else ids)
    return out


@pytest.mark.parametrize("latency", [0.0, 0.2])
def test_sensing_noise_is_gaussian_per_observer_and_neighbour_and_own_state_is_exact(latency):
    spec = load_map("circle_swap", n=8, radius=4.0)
    sigma = (0.05, 0.2, 0.4)  # position m, velocity m/s, acceleration m/s^2
    noise = dict(zip(("position", "velocity", "acceleration"), sigma, strict=True))
    arena = Arena(spec, ArenaOptions(sensing_noise=noise, sensing_latency=latency))
    rows = _run_seers(arena, 0, 60)
    lag = int(round(latency / spec.physics.dt))
    errors = [[], [], []]
    pairs = {}  # (step, body) -> the position errors of its observers
    for step, (_, observations) in enumerate(rows):
        truth = rows[max(0, step - lag)][0]
        lists = _lists(truth[0], arena.robot_ids, arena.sensing_range)
        for k, obs in enumerate(observations):
            me = arena.robot_ids[k]
            # the own state is exact, the lists are the true ones (noise moves nothing)
            np.testing.assert_array_equal(obs.position, truth[0][me])
            np.testing.assert_array_equal(obs.velocity, truth[1][me])
            np.testing.assert_array_equal(obs.acceleration, truth[2][me])
            assert obs.neighbours.ids.tolist() == lists[k]
            if step < lag:
                continue  # the first batch, again: its draws are counted once
            nb = obs.neighbours
            for c, sensed in enumerate((nb.positions, nb.velocities, nb.accelerations)):
                errors[c].append(sensed - truth[c][nb.ids])
            for j, e in zip(nb.ids, nb.positions - truth[0][nb.ids], strict=True):
                pairs.setdefault((step, int(j)), []).append(e)
    for c, s in enumerate(sigma):
        e = np.concatenate(errors[c])
        assert e.size > 3000
        assert np.all(np.abs(e.mean(axis=0)) < 4 * s / np.sqrt(len(e)))
        assert e.std() == pytest.approx(s, rel=0.05)
    # two observers of one body at one step get independent draws
    a, b = np.array([(v[0], v[1]) for v in pairs.values() if len(v) >= 2]).transpose(1, 0, 2)
    if lag == 0:
        assert not np.any(np.all(a == b, axis=1))
    r = np.corrcoef(a.ravel(), b.ravel())[0, 1]
    assert abs(r) < 4 / np.sqrt(a.size)


def test_noisy_batches_are_frozen_and_name_the_bodies():
    spec = load_map("circle_swap", n=5, radius=4.0)
    arena = Arena(spec, ArenaOptions(sensing_noise={"position": 0.1}, sensing_dropout=0.3))
    batches = []

    class Keep:
        def begin(self, arena, seed):
            pass

        def step(self, arena, sensing, result, actions):
            batches.append(sensing)

    arena.recorder = Keep()
    truth = arena.reset(0)
    arena.step()
    batch = batches[0]
    n = arena.world.n
    assert len(batch.positions) == n + len(batch.nb_index)  # a row per (robot, neighbour)
    np.testing.assert_array_equal(batch.positions[:n], truth.positions)
    everyone = batch.everyone()
    np.testing.assert_array_equal(everyone.ids[n:], batch.body_of(batch.nb_index))
    assert np.all(batch.body_of(batch.nb_index) < n)
    for name in ("positions", "velocities", "accelerations", "kinds", "nb_index", "row_bodies"):
        with pytest.raises(ValueError):
            getattr(batch, name).setflags(write=True)
    with pytest.raises(ValueError):
        batch.observation(0).position[0] = 0.0


def test_the_episode_log_keeps_the_bodies_sensed_under_noise():
    from nao_arena.episode_log import EpisodeRecorder

    spec = load_map("circle_swap", n=4, radius=4.0)
    arena = Arena(spec, ArenaOptions(sensing_noise={"velocity": 0.5}))  # nao: logged
    arena.recorder = EpisodeRecorder()
    arena.reset(1)
    states = [arena.state]
    for _ in range(3):
        states.append(arena.step().state)
    log = arena.recorder.finish(arena)
    for step in range(1, 4):
        lists = _lists(states[step - 1].positions, arena.robot_ids, arena.sensing_range)
        for k in range(4):
            assert log.neighbours(step, k).tolist() == lists[k]


@pytest.mark.parametrize("p", [0.3, 1.0])
def test_dropout_misses_each_neighbour_with_its_probability(p):
    spec = load_map("circle_swap", n=12, radius=5.0)
    arena = Arena(spec, ArenaOptions(sensing_dropout=p, max_neighbours=8))
    rows = _run_seers(arena, 4, 100)
    listed = missed = 0
    for truth, observations in rows:
        lists = _lists(truth[0], arena.robot_ids, arena.sensing_range, most=8)
        for k, obs in enumerate(observations):
            sensed = obs.neighbours.ids.tolist()
            # what is left of the true list, in its order (the cap is applied before)
            assert sensed == [j for j in lists[k] if j in sensed]
            listed += len(lists[k])
            missed += len(lists[k]) - len(sensed)
            np.testing.assert_array_equal(obs.neighbours.positions, truth[0][sensed])
    assert listed == 100 * 12 * 8
    tolerance = 4 * np.sqrt(p * (1 - p) / listed)  # 0.019 at p = 0.3
    assert abs(missed / listed - p) <= tolerance


def _heading(position, velocity, goal):
    """The heading (rad) of a robot by the definition (velocity; standing still: goal)."""
    if np.hypot(*velocity) >= 1e-6:
        return np.arctan2(velocity[1], velocity[0])
    to_goal = goal - position
    return np.arctan2(to_goal[1], to_goal[0]) if np.hypot(*to_goal) > 0 else None


@pytest.mark.parametrize(("fov", "most"), [(np.pi / 2, None), (2.5, 3), (5.0, None)])
def test_the_field_of_view_senses_exactly_the_bodies_in_view(fov, most):
    spec = load_map("crowd", n=12, seed=2)
    arena = Arena(spec, ArenaOptions(sensing_field_of_view=fov, max_neighbours=most))
    rows = _run_seers(arena, 0, 40)
    goals = arena.goals
    sensed_total = hidden = 0
    for truth, observations in rows:
        positions, velocities = truth[0], truth[1]
        angles = np.zeros((len(arena.robot_ids), len(positions)))
        for k, b in enumerate(arena.robot_ids):
            h = _heading(positions[b], velocities[b], goals[k])
            rel = positions - positions[b]
            off = np.abs(np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - h))))
            off[b] = 0.0  # itself (never sensed)
            assert not np.any(np.abs(off - fov / 2) < 1e-9)  # none on the edge of the view
            angles[k] = off
        in_view = _lists(
            positions,
            arena.robot_ids,
            arena.sensing_range,
            most,
            angles <= fov / 2,
        )
        everyone = _lists(positions, arena.robot_ids, arena.sensing_range)
        for k, obs in enumerate(observations):
            assert obs.neighbours.ids.tolist() == in_view[k]
            sensed_total += len(in_view[k])
            hidden += len(everyone[k]) - len(in_view[k])
    assert sensed_total > 0 and hidden > 0  # the view both shows and hides bodies


def test_a_robot_standing_still_looks_towards_its_goal():
    data = {
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "sensing": {"field_of_view": 2.0},  # 115 degrees
        "robots": [
            {"start": [0, 0], "goal": [5, 0]},
            {"start": [2, 0.5], "goal": [2, 5]},  # ahead of robot 0
            {"start": [-2, 0], "goal": [-2, 5]},  # behind it
            {"start": [0, 3], "goal": [0, 8]},  # beside it
        ],
    }
    arena = Arena(map_from_dict(data))
    arena.reset(0)
    assert arena.sensing().neighbour_ids(0).tolist() == [1]
    # moving, it looks where it goes: robot 0 heading +y sees robot 3 only
    wide = Arena(map_from_dict(data), ArenaOptions(sensing_field_of_view=2 * np.pi))
    wide.reset(0)
    assert wide.sensing().neighbour_ids(0).tolist() == [2, 1, 3]  # nearest first
    arena.state = dataclasses.replace(
        arena.state, velocities=np.array([[0.0, 1.0], [0, 0], [0, 0], [0, 0]])
    )
    assert arena.sensing().neighbour_ids(0).tolist() == [3]


class Pusher:
    """Commands a fixed sequence of accelerations (m/s^2), one per step."""

    def __init__(self, commands):
        self.commands = commands

    def reset(self, spec, rng):
        self.k = 0

    def act(self, obs):
        self.k += 1
        return np.array(self.commands[self.k - 1], dtype=float)


@pytest.mark.parametrize("lag", [0.05, 0.3, 2.0])
def test_the_actuation_lag_is_the_exact_first_order_response(lag):
    data = {
        "bounds": {"min": [-50, -50], "max": [50, 50]},
        "robots": [{"start": [0, 0], "goal": [1, 0], "a_max": 5.0, "v_max": 20.0}],
    }
    spec = map_from_dict(data)
    commands = [(1.0, 0.0)] * 6 + [(-0.5, 0.8)] * 7 + [(0.0, 0.0)] * 5 + [(2.0, -1.0)] * 4
    arena = Arena(spec, ArenaOptions(actuation_lag=lag))
    arena.reset(0)
    arena.agents = [Pusher(commands)]
    arena.agents[0].reset(None, None)
    dt = spec.physics.dt
    decay = np.exp(-dt / lag)
    expected = np.zeros(2)
    v0 = arena.state.velocities[0].copy()
    for c in commands:
        expected = np.asarray(c) + (expected - np.asarray(c)) * decay
        result = arena.step()
        v1 = result.state.velocities[0]
        np.testing.assert_allclose((v1 - v0) / dt, expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.commanded[0], expected, rtol=1e-12, atol=1e-15)
        v0 = v1.copy()
    # the response has not caught up with a command held for less than the lag
    assert np.all(np.abs(expected - commands[-1]) > 0.0)


def test_the_lag_state_starts_at_zero_each_episode():
    spec = load_map("circle_swap", n=3)
    arena = Arena(spec, ArenaOptions(agent="goal", actuation_lag=0.4))
    first = arena.run(2, max_steps=15)
    again = arena.run(2, max_steps=15)
    assert first.trajectory_hash == again.trajectory_hash


EVERYTHING = dict(
    sensing_noise={"position": 0.1, "velocity": 0.1, "acceleration": 0.2},
    sensing_dropout=0.2,
    sensing_field_of_view=3.0,
    sensing_occlusion=True,
    actuation_lag=0.3,
    actuation_noise=0.2,
)


def test_same_seed_same_run_with_every_model_on():
    spec = load_map("circle_swap", n=6, radius=4.0)
    runs = [Arena(spec, ArenaOptions(**EVERYTHING)).run(s, max_steps=40) for s in (7, 7, 8)]
    assert runs[0].trajectory_hash == runs[1].trajectory_hash != runs[2].trajectory_hash
    quiet = Arena(spec, ArenaOptions()).run(7, max_steps=40)
    assert quiet.trajectory_hash != runs[0].trajectory_hash


def test_each_random_model_draws_from_its_own_child_of_the_episode_seed():
    # the agents' generators and the actuation noise's are the children 0 .. R of the
    # episode's SeedSequence (as before the sensing models); then the sensing noise's, then
    # the dropout's
    spec = load_map("circle_swap", n=3, radius=4.0)
    r = 3
    children = np.random.SeedSequence(11).spawn(r + 3)
    arena = Arena(spec, ArenaOptions(actuation_noise=0.5, sensing_noise={"position": 0.2}))
    seers = _seers(arena, 11)
    truth = arena.state.positions.copy()
    commanded = arena.step().commanded[arena.robot_ids]
    clean = np.array([s.act(s.seen[-1]) for s in seers])  # the same state, the same push
    expected = np.random.default_rng(children[r]).normal(0.0, 0.5, (r, 2))
    np.testing.assert_allclose(commanded - clean, expected, atol=1e-12)
    sensed = np.concatenate([s.seen[-1].neighbours.positions for s in seers])
    ids = np.concatenate([s.seen[-1].neighbours.ids for s in seers])
    expected = np.random.default_rng(children[r + 1]).normal(0.0, 0.2, (len(ids), 2))
    np.testing.assert_allclose(sensed - truth[ids], expected, atol=1e-12)
    arena = Arena(spec, ArenaOptions(sensing_dropout=0.5))
    seers = _seers(arena, 11)
    arena.step()
    kept = np.random.default_rng(children[r + 2]).random(r * (r - 1)) >= 0.5
    assert sum(len(s.seen[-1].neighbours) for s in seers) == kept.sum()


def test_the_sensing_models_leave_the_actuation_noise_stream_alone():
    # "goal" ignores its neighbours: with the same actuation noise, what it senses of them
    # (noisy, dropped, out of view) changes nothing
    spec = load_map("circle_swap", n=6, radius=4.0)
    noisy = dict(actuation_noise=0.3, agent="goal")
    plain = Arena(spec, ArenaOptions(**noisy)).run(9, max_steps=40)
    sensing = {k: v for k, v in EVERYTHING.items() if k.startswith("sensing")}
    both = Arena(spec, ArenaOptions(**noisy, **sensing)).run(9, max_steps=40)
    assert plain.trajectory_hash == both.trajectory_hash


NEUTRAL = dict(
    sensing_noise={"position": 0.0, "velocity": 0.0, "acceleration": 0.0},
    sensing_dropout=0.0,
    sensing_field_of_view=2 * np.pi,
    sensing_occlusion=False,
    actuation_lag=0.0,
)


@pytest.mark.parametrize(("name", "agent"), [("circle_swap", "nao"), ("roundabout", "orca")])
def test_the_models_at_their_neutral_values_change_nothing(name, agent):
    spec = load_map(name)
    off = Arena(spec, ArenaOptions(agent=agent))
    neutral = Arena(spec, ArenaOptions(agent=agent, **NEUTRAL))
    off.reset(1)
    neutral.reset(1)
    for _ in range(40):
        a, b = off.sensing(), neutral.sensing()
        np.testing.assert_array_equal(a.nb_start, b.nb_start)
        np.testing.assert_array_equal(a.nb_index, b.nb_index)
        ra, rb = off.step(), neutral.step()
        np.testing.assert_array_equal(ra.commanded, rb.commanded)
        np.testing.assert_array_equal(ra.state.positions, rb.state.positions)
        np.testing.assert_array_equal(ra.state.velocities, rb.state.velocities)
    assert repr(off.summary()) == repr(neutral.summary())  # NaN fields as well
    # the same from the map
    data = {
        "bounds": {"min": [-5, -5], "max": [5, 5]},
        "robots": [{"start": [-2, 0], "goal": [2, 0]}, {"start": [2, 0.1], "goal": [-2, 0]}],
    }
    explicit = {
        **data,
        "sensing": {
            "noise": {"position": 0, "velocity": 0, "acceleration": 0},
            "dropout": 0,
            "field_of_view": 2 * np.pi,
            "occlusion": False,
        },
        "actuation": {"lag": 0},
    }
    hashes = {
        Arena(map_from_dict(d), ArenaOptions(agent=agent)).run(3, max_steps=30).trajectory_hash
        for d in (data, explicit)
    }
    assert len(hashes) == 1


def test_the_map_sets_the_models_and_the_options_override_it():
    data = {
        "bounds": {"min": [-5, -5], "max": [5, 5]},
        "sensing": {"noise": {"velocity": 0.2}, "dropout": 0.1, "field_of_view": 3.0},
        "actuation": {"lag": 0.5},
        "robots": [{"start": [0, 0], "goal": [1, 0]}],
    }
    spec = map_from_dict(data)
    imp = Arena(spec).imperfections
    assert (imp.noise, imp.dropout, imp.field_of_view, imp.lag) == ((0, 0.2, 0), 0.1, 3.0, 0.5)
    options = ArenaOptions(
        sensing_noise={"position": 1.0},
        sensing_dropout=0.0,
        sensing_field_of_view=1.0,
        actuation_lag=0.0,
    )
    imp = Arena(spec, options).imperfections
    assert (imp.noise, imp.dropout, imp.field_of_view, imp.lag) == ((1, 0, 0), 0.0, 1.0, 0.0)


@pytest.mark.parametrize(
    ("section", "value", "message"),
    [
        ("sensing", {"noise": {"position": -1}}, "sensing.noise.position: expected a non-negative"),
        ("sensing", {"noise": {"velocity": float("inf")}}, "sensing.noise.velocity: expected a"),
        ("sensing", {"noise": {"heading": 1}}, "sensing.noise.heading"),
        ("sensing", {"noise": 0.1}, "sensing.noise: expected a mapping"),
        ("sensing", {"dropout": 1.5}, "sensing.dropout: expected a number <= 1"),
        ("sensing", {"dropout": -0.1}, "sensing.dropout: expected a non-negative number"),
        ("sensing", {"field_of_view": 0}, "sensing.field_of_view: expected a positive number"),
        ("sensing", {"field_of_view": 7}, "sensing.field_of_view: expected a number <= 6.28"),
        ("actuation", {"lag": -0.1}, "actuation.lag: expected a non-negative number"),
        ("actuation", {"lag": True}, "actuation.lag: expected a number"),
    ],
)
def test_bad_map_values_are_one_line_errors(section, value, message):
    data = {
        "bounds": {"min": [-5, -5], "max": [5, 5]},
        section: value,
        "robots": [{"start": [0, 0], "goal": [1, 0]}],
    }
    with pytest.raises(MapError) as info:
        map_from_dict(data, "bad.yaml")
    text = str(info.value)
    assert "\n" not in text and text.startswith("bad.yaml: ")
    assert message in text, text


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"sensing_noise": {"position": -1.0}}, "sensing_noise.position: expected a finite"),
        ({"sensing_noise": {"acceleration": float("nan")}}, "sensing_noise.acceleration"),
        ({"sensing_noise": {"heading": 1.0}}, "sensing_noise: unknown key 'heading'"),
        ({"sensing_noise": 0.1}, "sensing_noise: expected a mapping"),
        ({"sensing_dropout": 1.01}, r"sensing_dropout: expected a finite number in \[0, 1\]"),
        ({"sensing_dropout": -0.5}, "sensing_dropout"),
        ({"sensing_field_of_view": 0.0}, r"sensing_field_of_view: .* in \(0, 2 pi\]"),
        ({"sensing_field_of_view": 6.3}, "sensing_field_of_view"),
        ({"actuation_lag": -1.0}, "actuation_lag: expected a finite number"),
        ({"actuation_lag": float("inf")}, "actuation_lag"),
        ({"actuation_lag": True}, "actuation_lag"),
        ({"sensing_occlusion": "maybe"}, "sensing_occlusion: expected True or False, got 'maybe'"),
        ({"sensing_occlusion": 1}, "sensing_occlusion: expected True or False"),
    ],
)
def test_bad_options_are_value_errors_naming_them(options, message):
    spec = load_map("circle_swap", n=2)
    with pytest.raises(ValueError, match=message) as info:
        Arena(spec, ArenaOptions(**options))
    assert "\n" not in str(info.value)


@given(
    st.integers(0, 2**32 - 1),
    st.floats(0.1, 2 * np.pi),
    st.integers(1, 6),
    st.integers(0, 12),
)
def test_in_view_is_the_angle_test_and_subset_keeps_the_order(seed, fov, robots, others):
    rng = np.random.default_rng(seed)
    n = robots + others
    positions = rng.uniform(-5, 5, (n, 2))
    observers = rng.permutation(n)[:robots].astype(np.int64)
    heading = rng.normal(size=(robots, 2))
    heading /= np.hypot(heading[:, 0], heading[:, 1])[:, None]
    heading[rng.random(robots) < 0.2] = np.nan  # no heading: all around
    lists = _lists(positions, observers, np.inf)
    start = np.concatenate(([0], np.cumsum([len(x) for x in lists]))).astype(np.int64)
    index = np.array([j for x in lists for j in x], dtype=np.int64)
    keep = in_view(start, index, observers, positions, heading, fov)
    expected = []
    for k, b in enumerate(observers):
        rel = positions[lists[k]] - positions[b]
        off = np.abs(
            np.angle(
                np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - np.arctan2(*heading[k][::-1])))
            )
        )
        assume(not np.any(np.abs(off - fov / 2) < 1e-9))
        expected += (np.isnan(heading[k, 0]) | (off <= fov / 2)).tolist()
    assert keep.tolist() == expected
    for most in (None, 2):
        s, i = subset(start, index, keep, most)
        for k in range(robots):
            mine = [
                j for j, ok in zip(lists[k], expected[start[k] : start[k + 1]], strict=True) if ok
            ]
            assert i[s[k] : s[k + 1]].tolist() == mine[:most]


def test_a_copy_mid_episode_continues_like_the_original():
    # the generators' states, the lag's state and the delayed batches are copied
    spec = load_map("circle_swap", n=5, radius=4.0)
    arena = Arena(spec, ArenaOptions(agent="orca", sensing_latency=0.2, **EVERYTHING))
    arena.reset(4)
    for _ in range(10):
        arena.step()
    twins = [copy.deepcopy(arena), pickle.loads(pickle.dumps(arena))]
    for _ in range(15):
        results = [a.step() for a in (arena, *twins)]
        for r in results[1:]:
            np.testing.assert_array_equal(r.commanded, results[0].commanded)
    assert len({a.summary().trajectory_hash for a in (arena, *twins)}) == 1


def _in_a_row(extra: dict | None = None) -> dict:
    """Three robots 2 m apart on a line (radius 0.5 m), each heading up."""
    return {
        "bounds": {"min": [-10, -10], "max": [10, 10]},
        "robots": [{"start": [2.0 * i, 0.0], "goal": [2.0 * i, 5.0]} for i in range(3)],
        **(extra or {}),
    }


def test_occlusion_hides_what_stands_behind_a_robot_or_a_wall():
    arena = Arena(map_from_dict(_in_a_row({"sensing": {"occlusion": True}})), ArenaOptions())
    arena.reset(0)
    assert [o.neighbours.ids.tolist() for o in arena.observations()] == [[1], [0, 2], [1]]
    # the option overrides the map
    arena = Arena(arena.spec, ArenaOptions(sensing_occlusion=False))
    arena.reset(0)
    assert [o.neighbours.ids.tolist() for o in arena.observations()] == [[1, 2], [0, 2], [1, 0]]
    # a wall between the first two: each sees only what is on its side
    walls = {"walls": [{"type": "segment", "a": [1.0, -3.0], "b": [1.0, 3.0], "thickness": 0.1}]}
    arena = Arena(map_from_dict(_in_a_row({**walls, "sensing": {"occlusion": True}})))
    arena.reset(0)
    assert [o.neighbours.ids.tolist() for o in arena.observations()] == [[], [2], [1]]


@pytest.mark.parametrize(("fov", "most"), [(2 * np.pi, None), (2.5, 3)])
def test_occlusion_senses_exactly_the_visible_bodies(fov, most):
    """In a crowd: each list is the bodies in range that are visible past the others in
    range (:func:`visible_witness`, checked against cast rays in tests/test_occlusion.py),
    in view, nearest first, cut to ``most``."""
    from nao_arena.occlusion import visible_witness

    spec = load_map("crowd", n=12, seed=2)
    arena = Arena(
        spec,
        ArenaOptions(sensing_occlusion=True, sensing_field_of_view=fov, max_neighbours=most),
    )
    rows = _run_seers(arena, 0, 30)
    hidden = sensed = 0
    for truth, observations in rows:
        positions, velocities = truth[0], truth[1]
        everyone = _lists(positions, arena.robot_ids, arena.sensing_range)
        for k, obs in enumerate(observations):
            b = int(arena.robot_ids[k])
            h = _heading(positions[b], velocities[b], arena.goals[k])
            seen = []
            for j in everyone[k]:
                if np.isnan(
                    visible_witness(
                        b,
                        j,
                        np.array(everyone[k]),
                        positions,
                        arena.world.radii,
                        arena.walls,
                        arena.wall_radius,
                    )
                ):
                    hidden += 1
                    continue
                rel = positions[j] - positions[b]
                if h is None or abs(np.angle(np.exp(1j * (np.arctan2(rel[1], rel[0]) - h)))) <= (
                    fov / 2
                ):
                    seen.append(j)
            want = seen if most is None else seen[:most]
            assert obs.neighbours.ids.tolist() == want
            sensed += len(want)
    assert sensed > 0 and hidden > 0  # bodies both seen and hidden


# ---------------------------------------------------------------------- env observations


def _env(**arena):
    import nao_arena

    return nao_arena.parallel_env("circle_swap", n=6, radius=4.0, arena=arena)


def test_env_observations_hold_what_the_robots_sense():
    """With sensing noise the env's neighbour rows are the noisy rows of the batch the
    arena's own step acts on (not the truth), and reading them draws nothing: a run
    that observes every step follows the trajectory of one that never does."""
    env = _env(sensing_noise={"position": 0.2, "velocity": 0.1})
    obs, _ = env.reset(seed=4)
    arena = env.unwrapped.arena if hasattr(env, "unwrapped") else env.arena
    batch = arena.sensed()
    own = batch.bodies[0]
    rows = batch.neighbour_ids(0)
    first = obs[env.agents[0]]
    got = first[17:19].astype(np.float64)  # the nearest neighbour's relative position
    want = batch.positions[rows[0]] - batch.positions[own]
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6)
    truth = arena.state.positions[batch.body_of(rows[:1])[0]] - arena.state.positions[own]
    assert np.max(np.abs(truth - want)) > 1e-3
    actions = {a: np.zeros(2, dtype=np.float32) for a in env.agents}
    watched = []
    for _ in range(5):
        obs, *_ = env.step(actions)
        watched.append(arena.state.positions.copy())
    quiet = Arena(arena.spec, arena.options)
    quiet.reset(4)
    for k in range(5):
        quiet.step({i: np.zeros(2) for i in range(len(quiet.robot_ids))})
        np.testing.assert_array_equal(quiet.state.positions, watched[k])


def test_env_observations_are_as_old_as_the_latency():
    """With 0.2 s of sensing latency a robot observes its own position of two periods
    ago; without models it observes the truth."""
    env = _env(sensing_latency=0.2)
    env.reset(seed=1)
    arena = env.unwrapped.arena if hasattr(env, "unwrapped") else env.arena
    name = env.agents[0]
    body = arena.robot_ids[0]
    history = [arena.state.positions[body].copy()]
    actions = {a: np.array([1.0, 0.5], dtype=np.float32) for a in env.agents}
    for _ in range(4):
        obs, *_ = env.step(actions)
        history.append(arena.state.positions[body].copy())
        np.testing.assert_allclose(obs[name][11:13], history[max(len(history) - 3, 0)], rtol=1e-6)
    exact = _env()
    obs, _ = exact.reset(seed=1)
    truth = (exact.unwrapped if hasattr(exact, "unwrapped") else exact).arena.state.positions
    np.testing.assert_allclose(obs[exact.agents[0]][11:13], truth[body], rtol=1e-6)
