"""Worker processes that each step several environments per message.

Gymnasium's ``AsyncVectorEnv`` (shared-memory observations, autoreset off) over ``workers``
processes, each holding a ``SyncVectorEnv`` of ``K = num_envs / workers`` environments
(:class:`EnvGroup`). A step sends each process one message with its K actions and gets back one
with K rewards and flags; the observations come through shared memory. A worker's info is empty
but when one of its environments ends an episode. So a step costs one round trip per process, not
one per environment: with one environment per process every step paid more in pipes and pickling
than the environment itself costs (docs/speed.md).

:class:`WorkerVecEnv` looks to its caller like a Gymnasium vector env of ``num_envs``
environments with autoreset off: ``reset(seed=[...], options={"reset_mask": ..., ...})``,
``step(actions)`` and ``close()``; environment ``i`` is environment ``i % K`` of process
``i // K``, and it sees the same seeds and actions, so it gives the same observations as in one
process.
"""

from __future__ import annotations

import signal
import time
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv
from gymnasium.vector.async_vector_env import AsyncState
from gymnasium.vector.utils import batch_space


class WorkerLost(RuntimeError):
    """A worker process ended while the vector waited on it (killed, out of memory, crashed)."""


class EnvGroup(gym.Env):
    """K environments stepped together in one worker process, seen by ``AsyncVectorEnv`` as one env
    whose observation, action, reward and flags carry a leading axis of K.

    ``reset(seed=..., options=...)`` takes the options of the whole vector: ``seeds`` and ``mask``
    (one per environment of the vector; this group reads its slice) and any other key, passed on
    to every environment as it is (``cells`` in the training vector)."""

    metadata: dict[str, Any] = {"render_modes": []}  # its own: AsyncVectorEnv writes into it

    def __init__(self, makers: Sequence[Callable[[], gym.Env]], first: int):
        self.envs = SyncVectorEnv(list(makers), autoreset_mode=AutoresetMode.DISABLED, copy=False)
        self.first, self.size = first, len(makers)
        self.single_observation_space = self.envs.single_observation_space
        self.single_action_space = self.envs.single_action_space
        self.observation_space = batch_space(self.single_observation_space, self.size)
        self.action_space = batch_space(self.single_action_space, self.size)

    def reset(self, *, seed=None, options=None):
        options = dict(options or {})
        own = slice(self.first, self.first + self.size)
        seeds, mask = options.pop("seeds", None), options.pop("mask", None)
        seed = None if seeds is None else list(seeds[own])
        if mask is not None:
            options["reset_mask"] = np.asarray(mask[own], dtype=np.bool_)
        observation: dict[str, np.ndarray]
        observation, _ = self.envs.reset(seed=seed, options=options)
        return observation, {}

    def step(self, action):
        observation: dict[str, np.ndarray]
        rewards: np.ndarray
        terminated: np.ndarray
        truncated: np.ndarray
        observation, rewards, terminated, truncated, info = self.envs.step(action)
        if info:  # an episode ended: its numbers, and which environments have them
            info = {
                "values": {key: value for key, value in info.items() if not key.startswith("_")},
                "masks": {key[1:]: value for key, value in info.items() if key.startswith("_")},
            }
        return observation, rewards, terminated, truncated, info

    def each_call(self, name: str, *args: Any, **kwargs: Any) -> tuple:
        """``name`` called (or, for an attribute, read) on each of this group's environments."""
        return self.envs.call(name, *args, **kwargs)

    def each_attr(self, name: str) -> tuple:
        """Attribute ``name`` of each of this group's environments."""
        return self.envs.get_attr(name)

    def close(self):
        self.envs.close()


def _group(makers: Sequence[Callable[[], gym.Env]], first: int) -> EnvGroup:
    return EnvGroup(makers, first)


class WorkerVecEnv:
    """``len(makers)`` environments in ``workers`` processes (``workers`` divides their number)."""

    def __init__(self, makers: Sequence[Callable[[], gym.Env]], workers: int, context: str | None = "forkserver"):
        from functools import partial

        num_envs = len(makers)
        if workers < 1 or num_envs % workers:
            raise ValueError(f"workers: got {workers} for {num_envs} environments; allowed: a divisor of {num_envs}")
        self.num_envs, self.workers, self.per_worker = num_envs, workers, num_envs // workers
        k = self.per_worker
        groups = [partial(_group, list(makers[w * k : (w + 1) * k]), w * k) for w in range(workers)]
        self.envs = AsyncVectorEnv(
            groups, shared_memory=True, copy=False, context=context, autoreset_mode=AutoresetMode.DISABLED
        )
        self.single_observation_space = self.envs.get_attr("single_observation_space")[0]
        self.single_action_space = self.envs.get_attr("single_action_space")[0]
        shared = self.envs.observations  # views of the shared memory, (workers, K, ...) each
        if not isinstance(shared, dict):
            raise TypeError(f"observations of the worker processes: got {type(shared).__name__}; allowed: a Dict space")
        self.observations = {key: value.reshape(num_envs, *value.shape[2:]) for key, value in shared.items()}

    @property
    def processes(self) -> list:
        """The worker processes (``multiprocessing`` Process objects), in order."""
        return list(self.envs.processes)

    def reset(self, *, seed: Sequence[int | None] | None = None, options: dict | None = None):
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        seeds = np.array(list(seed) if seed is not None else [None] * self.num_envs, dtype=object)
        shared = {**options, "seeds": seeds}
        outer = None
        if mask is not None:
            mask = np.asarray(mask, dtype=np.bool_)
            shared["mask"] = mask
            outer = mask.reshape(self.workers, self.per_worker).any(axis=1)
        self._guard(lambda: self.envs.reset(options=shared if outer is None else {**shared, "reset_mask": outer}))
        return self.observations, {}

    def step(self, actions: np.ndarray):
        actions = np.asarray(actions).reshape(self.workers, self.per_worker, *self.single_action_space.shape)
        _, rewards, terminated, truncated, info = self._guard(lambda: self.envs.step(actions))
        return (
            self.observations,
            rewards.reshape(self.num_envs),
            terminated.reshape(self.num_envs),
            truncated.reshape(self.num_envs),
            self._infos(info),
        )

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple:
        """``name`` called (or, for an attribute, read) on every environment, in order (as
        Gymnasium's vector envs' ``call``)."""
        groups = self._guard(lambda: self.envs.call("each_call", name, *args, **kwargs))
        return tuple(value for group in groups for value in group)

    def get_attr(self, name: str) -> tuple:
        """Attribute ``name`` of every environment, in order (as Gymnasium's vector envs' ``get_attr``)."""
        groups = self._guard(lambda: self.envs.call("each_attr", name))
        return tuple(value for group in groups for value in group)

    def _infos(self, info: dict) -> dict[str, np.ndarray]:
        """The infos of the groups as one vector env's: each key an array over all environments, with
        its ``_key`` mask."""
        if not info:
            return {}
        out: dict[str, np.ndarray] = {}
        for key, value in info["values"].items():
            if key.startswith("_"):  # the groups' own masks, one per process
                continue
            out[key] = value.reshape(self.num_envs, *value.shape[2:])
            out[f"_{key}"] = info["masks"][key].reshape(self.num_envs)
        return out

    def _guard(self, call: Callable[[], Any]) -> Any:
        """``call``, with a worker process that ended under it named in one error."""
        try:
            return call()
        except (EOFError, BrokenPipeError, ConnectionResetError):
            lost = self._lost()
            self.envs._state = AsyncState.DEFAULT  # nothing more is awaited from the processes
            self.close(terminate=True)
            raise WorkerLost(lost) from None

    def _lost(self) -> str:
        """Which process ended, and how (its exit is seen a moment after its pipe closes)."""
        deadline = time.monotonic() + 2.0
        while True:
            for index, process in enumerate(self.envs.processes):
                if not process.is_alive():
                    first = index * self.per_worker
                    return (
                        f"worker process {index} of {self.workers} (pid {process.pid}, environments {first} to "
                        f"{first + self.per_worker - 1}) {_exit(process.exitcode)} while the others waited on it; "
                        "every worker process is stopped"
                    )
            if time.monotonic() > deadline:
                return "a worker process's pipe closed while the vector waited on it; every worker process is stopped"
            time.sleep(0.01)

    def close(self, terminate: bool = False) -> None:
        if not self.envs.closed:
            self.envs.close(terminate=terminate)


def _exit(code: int | None) -> str:
    if code is None:
        return "closed its pipe"
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"
