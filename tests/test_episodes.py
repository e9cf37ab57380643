"""The shared episode loop (aaai.scoring.episodes.play): resets, callbacks, step limit and the result."""

import numpy as np

from aaai.scoring.episodes import play
from aaai.scoring.evaluation import run_episode
from aaai.scoring.policies import RandomPolicy


class Recorder:
    """A policy that records its resets and the observations it is given."""

    def __init__(self, env):
        self.space, self.resets, self.calls = env.action_space, [], 0

    def reset(self, seed):
        self.resets.append(seed)
        self.space.seed(seed)

    def __call__(self, observation):
        self.calls += 1
        return self.space.sample()


def test_play_stops_at_max_steps_and_calls_back_in_order(make_env):
    env = make_env(max_steps=50)
    policy, events = Recorder(env), []
    result = play(
        env,
        policy,
        7,
        options={"level": 1, "difficulty": 2},
        on_reset=lambda observation, info: events.append(("reset", info["seed"], len(policy.resets))),
        on_step=lambda step, observation, reward, info: events.append((step, info["steps"])),
        max_steps=5,
    )
    assert events == [("reset", 7, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 5)]  # on_reset before the policy's
    assert policy.resets == [7] and policy.calls == 5 and env.level_spec.level == 1
    assert result.steps == 5 and result.info["steps"] == 5 and result.end is None
    assert not (result.terminated or result.truncated)
    assert 0 <= result.step_seconds <= result.wall_seconds


def test_play_to_the_end_and_the_scoreboard_row(make_env):
    env = make_env(max_steps=30)
    result = play(env, RandomPolicy(env), 3, options={"level": 0, "difficulty": 0})
    assert result.truncated and result.end == "time" and result.steps == 30
    row = run_episode(env, RandomPolicy(env), 0, 0, 3)  # the same episode again, as `aaai eval` scores it
    assert row["steps"] == 30 and row["return"] == round(result.episode_return, 6)
    assert np.isfinite(row["wall_seconds"])
