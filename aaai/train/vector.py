"""Parallel environments whose episodes are assigned by a sampler living in this process.

Workers are Gymnasium vector envs with autoreset off: in this process (SyncVectorEnv) or in
worker processes (aaai.train.workers: AsyncVectorEnv with shared memory over processes that each
step several environments), as ``train.vector`` says; ``train.processes`` sets how many. When episodes end, this process
records their returns with the curriculum, draws each finished worker's next (level,
difficulty, seed), and resets just those workers with it; workers keep no sampler state.
Each step a worker sends back only its observation, reward and flags; the info the learner uses
(``EPISODE_INFO_KEYS`` and the episode's reward shaping) comes once, when the episode ends.
"""

from __future__ import annotations

import os
from functools import partial

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from aaai.config import Config, TrainConfig, env_part
from aaai.scoring.runs import Episode
from aaai.train.curriculum import Curriculum
from aaai.train.workers import WorkerVecEnv

EPISODE_INFO_KEYS = ("food_eaten", "wall_hits", "fell", "blew_up", "max_reward")
VECTOR_MODES = ("auto", "sync", "async")


def usable_cores() -> int:
    """The CPU cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def runs_in_process(mode: str, num_envs: int, cores: int | None = None) -> bool:
    """Does ``train.vector`` = ``mode`` step the workers in this process (SyncVectorEnv)?

    ``auto``: in this process when one worker, or when the workers would outnumber the cores left
    beside this one (which runs the learner): there, worker processes only wait on one another and
    on the learner, and every step pays a round trip between processes. Subprocesses otherwise.
    """
    if mode not in VECTOR_MODES:
        raise ValueError(f"train.vector: got {mode!r}; allowed: {', '.join(VECTOR_MODES)}")
    if mode != "auto":
        return mode == "sync"
    free = (usable_cores() if cores is None else cores) - 1
    return num_envs == 1 or num_envs > free


def worker_processes(train: TrainConfig, cores: int | None = None) -> int:
    """Processes the rllib backend (EnvRunners) and the student (episode workers) start:
    ``train.processes``, or with 0 ``train.num_envs`` but no more than the usable cores. Apart from
    ``num_envs`` so that stable-baselines3 can step many environments in this process
    (``train.vector: sync``) without the other learners starting one process per environment."""
    asked = int(train.processes)
    if asked > 0:
        return asked
    return max(1, min(int(train.num_envs), usable_cores() if cores is None else cores))


def group_processes(train: TrainConfig, num_envs: int, cores: int | None = None) -> int:
    """Worker processes of an asynchronous vector of ``num_envs`` environments: the most, up to
    :func:`worker_processes`, that share them out evenly (each steps ``num_envs`` / that many)."""
    most = min(num_envs, worker_processes(train, cores))
    return max(w for w in range(1, most + 1) if num_envs % w == 0)


class AssignedCell(gym.Wrapper):
    """In worker ``index``: reads its own (level, difficulty) from options shared by all workers.
    Its info is empty but at an episode's end: then ``EPISODE_INFO_KEYS`` and ``shaping``, the
    episode's reward shaping in all."""

    def __init__(self, env: gym.Env, index: int):
        super().__init__(env)
        self.index = index
        self.shaping = 0.0

    def reset(self, *, seed=None, options=None):
        cells = (options or {}).get("cells")
        own = {}
        if cells is not None and cells[self.index] is not None:
            level, difficulty = cells[self.index]
            own = {"level": level, "difficulty": difficulty}
        observation, _ = self.env.reset(seed=seed, options=own)
        self.shaping = 0.0
        return observation, {}

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self.shaping += info["reward_terms"]["shaping"]
        if not (terminated or truncated):
            return observation, reward, terminated, truncated, {}
        return (
            observation,
            reward,
            terminated,
            truncated,
            {"shaping": self.shaping, **{key: info[key] for key in EPISODE_INFO_KEYS}},
        )


def _make_worker(index: int, config: Config) -> gym.Env:
    from aaai.env import AnimalAIEnv

    return AssignedCell(AnimalAIEnv(config=env_part(config, config.train.reward_shaping)), index)


class CurriculumVecEnv:
    """``num_envs`` environments stepping together; every episode's cell and seed come from ``curriculum``."""

    def __init__(self, config: Config, curriculum: Curriculum, num_envs: int, asynchronous: bool | None = None):
        """``asynchronous``: worker processes (True) or this process (False); None: as
        ``train.vector`` in ``config`` says (see ``runs_in_process``)."""
        self.curriculum = curriculum
        self.num_envs = num_envs
        makers = [partial(_make_worker, i, config) for i in range(num_envs)]
        if asynchronous is None:
            asynchronous = not runs_in_process(config.train.vector, num_envs)
        self.asynchronous = asynchronous
        self.envs: WorkerVecEnv | SyncVectorEnv
        if asynchronous:
            self.envs = WorkerVecEnv(makers, group_processes(config.train, num_envs))
        else:
            self.envs = SyncVectorEnv(makers, autoreset_mode=AutoresetMode.DISABLED, copy=False)
        self.single_observation_space = self.envs.single_observation_space
        self.single_action_space = self.envs.single_action_space
        self.assigned: list[tuple[int, int, int]] = []
        self.returns = np.zeros(num_envs)
        self.lengths = np.zeros(num_envs, dtype=np.int64)

    def reset(self):
        self.assigned = [self.curriculum.sample() for _ in range(self.num_envs)]
        observation: dict[str, np.ndarray]
        observation, _ = self.envs.reset(
            seed=[seed for *_, seed in self.assigned], options={"cells": [cell[:2] for cell in self.assigned]}
        )
        self.returns[:] = 0.0
        self.lengths[:] = 0
        return _copy(observation)

    def step(self, actions):
        """Steps every worker; returns (obs, rewards, terminated, truncated, finished episodes, final obs).

        ``final obs`` maps a finished worker's index to the last observation of its episode; its entry
        in ``obs`` is already the first observation of its next episode.
        """
        observation: dict[str, np.ndarray]
        rewards: np.ndarray
        terminated: np.ndarray
        truncated: np.ndarray
        observation, rewards, terminated, truncated, infos = self.envs.step(actions)
        self.returns += rewards
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
        return _copy(observation), rewards, terminated, truncated, finished, final_observations

    def _finish(self, i: int, infos: dict) -> Episode:
        level, difficulty, seed = self.assigned[i]
        episode = Episode(
            i,
            level,
            difficulty,
            seed,
            float(self.returns[i]),
            float(self.returns[i] - infos["shaping"][i]),
            int(self.lengths[i]),
            **{key: infos[key][i].item() for key in EPISODE_INFO_KEYS},
        )
        self.curriculum.record(level, difficulty, episode.task_return, episode.max_reward)
        self.returns[i] = 0.0
        self.lengths[i] = 0
        return episode

    def close(self) -> None:
        self.envs.close()


def _copy(observation: dict) -> dict:
    """A copy of the vector env's observation buffers (they are written over in place by the next
    step; a learner keeps the last observation until then)."""
    return {key: value.copy() for key, value in observation.items()}
