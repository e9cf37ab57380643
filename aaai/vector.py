"""Parallel environments whose episodes are assigned by a sampler living in this process.

Workers are Gymnasium vector-env processes with autoreset off. When episodes end, this process
records their returns with the curriculum, draws each finished worker's next (level,
difficulty, seed), and resets just those workers with it; workers keep no sampler state.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import gymnasium as gym
import numpy as np
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv

from aaai.config import env_part
from aaai.curriculum import Curriculum

EPISODE_INFO_KEYS = ("food_eaten", "wall_hits", "fell", "blew_up", "max_reward")


@dataclass
class Episode:
    """A finished training episode."""
    worker: int
    level: int
    difficulty: int
    seed: int
    episode_return: float  # what the learner got, shaping included
    task_return: float  # the task's own reward: what the curriculum and the scoreboard count
    length: int
    food_eaten: int
    wall_hits: int
    fell: bool
    blew_up: bool
    max_reward: float


class AssignedCell(gym.Wrapper):
    """In worker ``index``: reads its own (level, difficulty) from options shared by all workers."""

    def __init__(self, env: gym.Env, index: int):
        super().__init__(env)
        self.index = index

    def reset(self, *, seed=None, options=None):
        cells = (options or {}).get("cells")
        own = {}
        if cells is not None and cells[self.index] is not None:
            level, difficulty = cells[self.index]
            own = {"level": level, "difficulty": difficulty}
        return self.env.reset(seed=seed, options=own)


def _make_worker(index: int, config: dict) -> gym.Env:
    from aaai.env import AnimalAIEnv

    return AssignedCell(AnimalAIEnv(config=env_part(config, config["train"]["reward_shaping"])), index)


class CurriculumVecEnv:
    """``num_envs`` environments stepping together; every episode's cell and seed come from ``curriculum``."""

    def __init__(self, config: dict, curriculum: Curriculum, num_envs: int, asynchronous: bool = True):
        self.curriculum = curriculum
        self.num_envs = num_envs
        makers = [partial(_make_worker, i, config) for i in range(num_envs)]
        if asynchronous:
            self.envs = AsyncVectorEnv(makers, autoreset_mode=AutoresetMode.DISABLED, context="forkserver")
        else:
            self.envs = SyncVectorEnv(makers, autoreset_mode=AutoresetMode.DISABLED)
        self.single_observation_space = self.envs.single_observation_space
        self.single_action_space = self.envs.single_action_space
        self.assigned: list[tuple[int, int, int]] = []
        self.returns = np.zeros(num_envs)
        self.shaping = np.zeros(num_envs)
        self.lengths = np.zeros(num_envs, dtype=np.int64)

    def reset(self):
        self.assigned = [self.curriculum.sample() for _ in range(self.num_envs)]
        observation, _ = self.envs.reset(seed=[seed for *_, seed in self.assigned],
                                         options={"cells": [cell[:2] for cell in self.assigned]})
        self.returns[:] = 0.0
        self.shaping[:] = 0.0
        self.lengths[:] = 0
        return observation

    def step(self, actions):
        """Steps every worker; returns (obs, rewards, terminated, truncated, finished episodes, final obs).

        ``final obs`` maps a finished worker's index to the last observation of its episode; its entry
        in ``obs`` is already the first observation of its next episode.
        """
        observation, rewards, terminated, truncated, infos = self.envs.step(actions)
        self.returns += rewards
        self.shaping += infos["reward_terms"]["shaping"]
        self.lengths += 1
        done = np.logical_or(terminated, truncated)
        finished: list[Episode] = []
        final_observations: dict[int, dict] = {}
        if done.any():
            for i in np.flatnonzero(done):
                final_observations[int(i)] = {key: np.array(value[i]) for key, value in observation.items()}
                finished.append(self._finish(int(i), infos))
                self.assigned[i] = self.curriculum.sample()
            cells = [self.assigned[i][:2] if done[i] else None for i in range(self.num_envs)]
            seeds = [self.assigned[i][2] if done[i] else None for i in range(self.num_envs)]
            observation, _ = self.envs.reset(seed=seeds, options={"reset_mask": done, "cells": cells})
        return observation, rewards, terminated, truncated, finished, final_observations

    def _finish(self, i: int, infos: dict) -> Episode:
        level, difficulty, seed = self.assigned[i]
        episode = Episode(i, level, difficulty, seed, float(self.returns[i]),
                          float(self.returns[i] - self.shaping[i]), int(self.lengths[i]),
                          **{key: infos[key][i].item() for key in EPISODE_INFO_KEYS})
        self.curriculum.record(level, difficulty, episode.task_return, episode.max_reward)
        self.returns[i] = 0.0
        self.shaping[i] = 0.0
        self.lengths[i] = 0
        return episode

    def close(self) -> None:
        self.envs.close()
