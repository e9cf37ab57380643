"""`aaai demos`: a policy's episodes as a Minari dataset, the Farama standard for offline RL.

Each episode holds the agent's own observations (the ordinary Dict observation, nothing
privileged), the actions in the env's action mode, the rewards (the task's own: no shaping),
terminations and truncations; its metadata holds the episode's seed and its options
``{"level": …, "difficulty": …}``, so that ``env.reset(seed=seed, options=options)`` on the
dataset's environment (``dataset.recover_environment()``) and the recorded actions replay it bit
for bit. Datasets are written with Minari's arrow storage (the ``demos`` extra) into ``--out``,
episodes in batches, so an interrupted recording resumes where it stopped.

    aaai demos --policy reference --levels 0-12 --difficulty 0-10 -k 2 --action-mode gait --out demos
    MINARI_DATASETS_PATH=demos python -c "import minari; print(minari.load_dataset('aaai/reference-v0'))"
"""

from __future__ import annotations

import contextlib
import os
import warnings
from pathlib import Path
from typing import Callable, Iterator

import gymnasium as gym
import numpy as np

from aaai.config import Config, ConfigError, env_part
from aaai.scoring.episodes import play
from aaai.scoring.policies import Policy, as_policy

DEFAULT_ID = "aaai/{policy}-v0"
BATCH = 10  # episodes written to the dataset at a time: at most this many are lost to a crash


@contextlib.contextmanager
def datasets_path(folder: Path) -> Iterator[None]:
    """Minari reads and writes datasets under MINARI_DATASETS_PATH: point it at ``folder`` meanwhile."""
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(folder.absolute())
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def dataset_id_for(policy: str) -> str:
    name = "".join(c if c.isalnum() else "-" for c in Path(policy).name or policy).strip("-") or "policy"
    return DEFAULT_ID.format(policy=name.lower())


def record_episode(env, policy: Callable, level: int, difficulty: int, seed: int, episode_id: int):
    """Plays one episode; its Minari EpisodeBuffer (observations one longer than actions)."""
    from minari.data_collector import EpisodeBuffer

    options = {"level": level, "difficulty": difficulty}
    observations, actions, rewards = [], [], []

    def start(observation, info) -> None:  # play resets the policy it is given: here that is `act`
        observations.append(observation)
        if hasattr(policy, "reset"):
            policy.reset(seed)

    def act(observation):
        action = np.asarray(policy(observation), env.action_space.dtype)
        actions.append(action)
        return action

    def step(_, observation, reward, info) -> None:
        observations.append(observation)
        rewards.append(reward)

    result = play(env, act, seed, options=options, on_reset=start, on_step=step)
    terminations = [False] * (len(actions) - 1) + [result.terminated]
    truncations = [False] * (len(actions) - 1) + [result.truncated]
    stacked = {key: np.stack([o[key] for o in observations]) for key in observations[0]}
    return EpisodeBuffer(
        id=episode_id,
        seed=seed,
        options=options,
        observations=stacked,
        actions=np.stack(actions),
        rewards=rewards,
        terminations=terminations,
        truncations=truncations,
    )


def record(
    policy: Policy | str,
    episodes: list[tuple[int, int, int]],
    out: Path,
    config: Config,
    dataset_id: str | None = None,
    on_episode: Callable[[int], None] | None = None,
) -> str:
    """Records ``episodes`` ((level, difficulty, seed) each) of the policy into the Minari dataset
    ``dataset_id`` under ``out``; resumes a dataset of the same id there (its first episodes must
    be the plan's). Returns the dataset id."""
    import minari

    policy = as_policy(policy)
    policy_name = policy.name
    dataset_id = dataset_id or dataset_id_for(policy_name)
    env_config = env_part(config, shaping=0.0).env_dict()  # the task's own reward; plain data in the env spec
    env = gym.make("aaai/AnimalAI-v0", config=env_config, disable_env_checker=True)
    out.mkdir(parents=True, exist_ok=True)
    try:
        acting = policy.build(env.unwrapped)
        with datasets_path(out):
            dataset = None
            done = 0
            if dataset_id in minari.list_local_datasets():
                dataset = minari.load_dataset(dataset_id)
                done = _check_prefix(dataset, episodes, dataset_id)
            buffer = []
            for index in range(done, len(episodes)):
                level, difficulty, seed = episodes[index]
                buffer.append(record_episode(env.unwrapped, acting, level, difficulty, seed, index))
                if on_episode:
                    on_episode(index)
                if len(buffer) == BATCH or index + 1 == len(episodes):
                    if dataset is None:
                        with warnings.catch_warnings():  # Minari asks for an e-mail and a code link: not ours to give
                            warnings.simplefilter("ignore", UserWarning)
                            dataset = minari.create_dataset_from_buffers(
                                dataset_id,
                                buffer,
                                env=env,
                                algorithm_name=policy_name,
                                data_format="arrow",
                                description=f"aaai: episodes of the policy {policy_name!r}; each episode's metadata "
                                "holds its seed and options (level, difficulty)",
                                author="aaai demos",
                            )
                    else:
                        dataset.update_dataset_from_buffer(buffer)
                    buffer = []
    finally:
        env.close()
    return dataset_id


def _check_prefix(dataset, episodes: list[tuple[int, int, int]], dataset_id: str) -> int:
    """How many of the plan's episodes the dataset already holds; refuses a dataset of another plan."""
    metadata = list(dataset.storage.get_episode_metadata(range(dataset.total_episodes)))
    for index, meta in enumerate(metadata):
        options = meta.get("options") or {}
        found = (options.get("level"), options.get("difficulty"), meta.get("seed"))
        if index >= len(episodes) or found != episodes[index]:
            raise ConfigError(
                f"--out: dataset {dataset_id!r} already holds episode {index} = (level, difficulty, seed) "
                f"{found}, which this recording would not make; choose another --out or --dataset-id"
            )
    return len(metadata)


def replay(dataset, index: int) -> tuple[list[float], dict]:
    """Re-runs episode ``index`` of a dataset in a fresh environment with its recorded actions;
    returns the rewards and the observations (stacked), to compare with the dataset's."""
    episode = dataset[index]
    meta = next(iter(dataset.storage.get_episode_metadata([dataset.episode_indices[index]])))
    env = dataset.recover_environment()
    try:
        observation, _ = env.reset(seed=meta["seed"], options=meta["options"])
        observations, rewards = [observation], []
        for action in episode.actions:
            observation, reward, terminated, truncated, _ = env.step(action)
            observations.append(observation)
            rewards.append(reward)
    finally:
        env.close()
    return rewards, {key: np.stack([o[key] for o in observations]) for key in observations[0]}
