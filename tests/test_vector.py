"""The training workers (aaai.vector): what a finished episode reports, and what the curriculum counts."""
import numpy as np
import pytest

from aaai.config import env_part, load_config
from aaai.curriculum import Curriculum
from aaai.env import AnimalAIEnv
from aaai.vector import CurriculumVecEnv


def replay(config: dict, shaping: float, episode, actions) -> float:
    """The return of ``actions`` in a plain environment on the episode's level, seed and cell."""
    env = AnimalAIEnv(config=env_part(config, shaping))
    try:
        env.reset(seed=episode.seed, options={"level": episode.level, "difficulty": episode.difficulty})
        total = 0.0
        for action in actions:
            _, reward, terminated, truncated, _ = env.step(action)
            total += reward
            if terminated or truncated:
                break
        return total
    finally:
        env.close()


def test_the_task_return_leaves_out_the_shaping_the_learner_gets():
    config = load_config(rays=False, max_steps=40, reward_shaping=5.0)
    curriculum = Curriculum([0], [0], seed=3)
    vec = CurriculumVecEnv(config, curriculum, num_envs=1, asynchronous=False)
    rng = np.random.default_rng(0)
    actions, finished = [], []
    try:
        vec.reset()
        while not finished:
            action = rng.uniform(-1, 1, (1, *vec.single_action_space.shape)).astype(np.float32)
            actions.append(action[0])
            finished = vec.step(action)[4]
    finally:
        vec.close()
    (episode,) = finished
    assert (episode.level, episode.difficulty, episode.length) == (0, 0, len(actions))
    unshaped, shaped = replay(config, 0.0, episode, actions), replay(config, 5.0, episode, actions)
    assert abs(shaped - unshaped) > 1e-3  # the flailing body moved its head: shaping paid something
    assert episode.episode_return == pytest.approx(shaped, abs=1e-9)  # the learner's reward
    assert episode.task_return == pytest.approx(unshaped, abs=1e-9)  # the task's own: what is scored
    assert list(curriculum.returns[(0, 0)]) == [episode.task_return]  # and what the curriculum counts
