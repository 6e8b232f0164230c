"""The imperfect world: sensing latency (agents act on what they sensed ``latency`` s ago)
and actuation noise (Gaussian noise on the robots' commands), set in the map or in
:class:`~nao_arena.arena.ArenaOptions`; off by default (the golden episodes guard that)."""

from __future__ import annotations

import numpy as np
import pytest

from nao_arena.arena import Arena, ArenaOptions
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
