"""The training workers (aaai.train.vector): what a finished episode reports, and what the curriculum counts."""

import numpy as np
import pytest

from aaai.config import Config, env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.train.curriculum import Curriculum
from aaai.train.vector import EPISODE_INFO_KEYS, CurriculumVecEnv


def replay(config: Config, shaping: float, episode, actions) -> float:
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


def test_auto_steps_in_process_when_workers_would_outnumber_the_free_cores():
    from aaai.train.vector import runs_in_process

    assert runs_in_process("auto", 2, cores=2)  # 2 workers, 1 core beside the learner's
    assert runs_in_process("auto", 4, cores=4)
    assert runs_in_process("auto", 1, cores=16)  # one worker never gains from its own process
    assert not runs_in_process("auto", 2, cores=4)
    assert runs_in_process("sync", 2, cores=64) and not runs_in_process("async", 8, cores=2)
    config = load_config(num_envs=2, vector="sync")
    vec = CurriculumVecEnv(config, Curriculum([0], [0], seed=0), num_envs=2)
    try:
        assert not vec.asynchronous  # None: as train.vector says
    finally:
        vec.close()


def test_workers_send_only_what_the_learner_reads():
    config = load_config(rays=False, max_steps=12, num_envs=1)
    vec = CurriculumVecEnv(config, Curriculum([0], [0], seed=1), num_envs=1, asynchronous=False)
    try:
        vec.reset()
        infos = [vec.envs.step(np.zeros((1, 8), np.float32))[4] for _ in range(12)]
    finally:
        vec.close()
    assert all(info == {} for info in infos[:-1])  # nothing while the episode runs
    assert {key for key in infos[-1] if not key.startswith("_")} == {"shaping", *EPISODE_INFO_KEYS}


def _weights(run) -> dict:
    import io
    import zipfile

    import torch

    with zipfile.ZipFile(run / "final" / "model.zip") as archive:
        return torch.load(io.BytesIO(archive.read("policy.pth")), map_location="cpu", weights_only=True)


def test_ppo_learns_the_same_weights_in_process_and_in_worker_processes(tmp_path):
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    from aaai.train.training import train

    config = load_config(
        levels="0-1",
        difficulties="0-1",
        max_steps=60,
        total_steps=384,
        num_envs=2,
        n_steps=64,
        batch_size=64,
        n_epochs=2,
        net_width=16,
        checkpoint_every=10**6,
        heatmap_every=10**6,
    )
    runs = {}
    for name, asynchronous in (("sync", False), ("async", True)):
        runs[name] = tmp_path / name
        train(runs[name], config, asynchronous=asynchronous, say=lambda message: None)
    sync, async_ = _weights(runs["sync"]), _weights(runs["async"])
    assert sync.keys() == async_.keys()
    assert all(torch_equal(sync[key], async_[key]) for key in sync)
    episodes = [(run / "episodes.csv").read_text() for run in runs.values()]
    assert episodes[0] == episodes[1] and episodes[0].count("\n") > 5  # the same episodes, several of them


def torch_equal(a, b) -> bool:
    return bool((a == b).all())


@pytest.mark.parametrize("asynchronous", [False, True])
def test_an_observation_handed_out_stays_as_it_was_after_the_next_step(asynchronous):
    """A learner keeps the last observation and stores it after the next step (stable-baselines3
    does): the next step must not write over it."""
    config = load_config(max_steps=30, num_envs=2)
    vec = CurriculumVecEnv(config, Curriculum([0], [0], seed=2), num_envs=2, asynchronous=asynchronous)
    rng = np.random.default_rng(0)
    try:
        vec.reset()
        for _ in range(40):  # across the end of the episodes (30 steps) and their resets
            observation = vec.step(rng.uniform(-1, 1, (2, 8)).astype(np.float32))[0]
            kept = {key: value.copy() for key, value in observation.items()}
            vec.step(rng.uniform(-1, 1, (2, 8)).astype(np.float32))
            assert all(np.array_equal(observation[key], kept[key]) for key in kept)
    finally:
        vec.close()


def test_processes_are_apart_from_num_envs():
    """16 environments stepping in this process do not make the rllib backend or the student start 16
    processes: train.processes (0: num_envs up to the usable cores) sets those."""
    from aaai.config import ConfigError
    from aaai.train.student import DaggerSettings
    from aaai.train.vector import worker_processes

    many = load_config(num_envs=16, vector="sync")
    assert worker_processes(many.train, cores=2) == 2
    assert worker_processes(load_config(num_envs=2).train, cores=8) == 2
    assert worker_processes(load_config(num_envs=16, processes=3).train, cores=2) == 3
    assert DaggerSettings.from_config(load_config(num_envs=16, processes=3)).workers == 3
    with pytest.raises(ConfigError, match="processes"):
        load_config(processes=-1)


def test_rllib_env_runners_follow_processes():
    """The rllib backend's EnvRunners come from train.processes; the num_envs environments are shared
    out over them and a rollout is still n_steps x num_envs steps."""
    pytest.importorskip("ray.rllib", reason="needs the ray extra, which make test installs")
    from aaai.train.rllib_learner import ppo_config
    from aaai.train.vector import worker_processes

    config = load_config(num_envs=16, processes=2, n_steps=128)
    runners = worker_processes(config.train)
    rl = ppo_config(config, "sampler", runners)
    assert (rl.num_env_runners, rl.num_envs_per_env_runner) == (2, 8)
    assert rl.train_batch_size_per_learner == 128 * 16
