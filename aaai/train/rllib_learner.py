"""`aaai train --backend rllib`: RLlib PPO (new API stack) with the paper's curriculum as one Ray actor.

The sampler (:class:`aaai.train.curriculum.Curriculum`) lives in a single Ray actor. Every environment,
in whichever EnvRunner process (or node) it runs, asks the actor for its next (level, difficulty,
seed) at each reset and tells it the finished episode (its task return: the reward without the
``shaping`` term) when the episode ends; environments hold no sampler state. The Dict observation
is flattened by RLlib's ``FlattenObservations`` env-to-module connector, and RLlib's default MLP
RLModule does the rest.

The run folder is the local trainer's (aaai/scoring/runs.py): config.yaml, versions.json, episodes.csv,
curriculum.png, checkpoints/step_N/ and final/, each holding state.json (the step and the
sampler's state) and, in place of stable-baselines3's model.zip, ``rllib/`` (the Algorithm
checkpoint). Episodes and checkpoints are handled at the end of each training iteration (one
iteration = ``train.n_steps`` x ``train.num_envs`` environment steps), so steps in episodes.csv and
checkpoints fall on iteration boundaries. A resume continues from the newest readable saved point.
"""

from __future__ import annotations

import math
import shutil
import tempfile
import uuid
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np

from aaai.config import Config, ConfigError, env_part, load_config
from aaai.scoring.runs import CHECKPOINT_FOLDER, RunFolder, check_writable
from aaai.train.curriculum import Curriculum
from aaai.train.training import (
    Tracker,
    TrainResult,
    check_budget_left,
    check_trainable,
    move_end,
    with_proprioception,
)
from aaai.train.vector import EPISODE_INFO_KEYS, Episode, worker_processes

ENV_NAME = "aaai-curriculum"
MAX_RUNNER_RESTARTS = 100  # replacements of failed EnvRunners over a run, before it gives up


# --- the sampler actor ----------------------------------------------------------------------
class CurriculumService:
    """The curriculum as a service (made a Ray actor by :func:`start_curriculum_actor`): hands out
    the next (level, difficulty, seed), records finished episodes, and keeps them until the trainer
    collects them for episodes.csv."""

    def __init__(self, config: Config, state: dict | None = None):
        self.curriculum = Curriculum.from_config(config)
        if state is not None:
            self.curriculum.load_state_dict(state)
        self.finished: list[dict] = []

    def sample(self) -> tuple[int, int, int]:
        return self.curriculum.sample()

    def record(self, episode: dict) -> None:
        self.curriculum.record(
            episode["level"], episode["difficulty"], episode["task_return"], episode.get("max_reward")
        )  # with it, whether the episode passed
        self.finished.append(episode)

    def collect(self) -> list[dict]:
        """The episodes finished since the last call, in the order they were recorded."""
        finished, self.finished = self.finished, []
        return finished

    def state_dict(self) -> dict:
        return self.curriculum.state_dict()

    def probabilities(self) -> list[float]:
        return [float(p) for p in self.curriculum.probabilities()]


def start_curriculum_actor(config: Config, state: dict | None = None, name: str | None = None):
    """The one sampler actor of a run (named, so that environments in other processes can find it)."""
    import ray

    name = name or f"aaai-curriculum-{uuid.uuid4().hex[:12]}"
    service: Any = ray.remote(num_cpus=0, max_restarts=0)(CurriculumService)  # an actor class, made by Ray
    actor = service.options(name=name).remote(config, state)
    ray.get(actor.state_dict.remote())  # up and running before any environment asks it
    return actor, name


class CurriculumProxy:
    """What :class:`aaai.train.training.Tracker` needs of a curriculum, read from the actor."""

    def __init__(self, actor, config: Config):
        self.actor, self.config = actor, config

    def state_dict(self) -> dict:
        import ray

        return ray.get(self.actor.state_dict.remote())

    def write_heatmap(self, path) -> None:  # drawn here (the driver's file system), from the actor's state
        curriculum = Curriculum.from_config(self.config)
        curriculum.load_state_dict(self.state_dict())
        curriculum.write_heatmap(path)


# --- the environment in the EnvRunners ------------------------------------------------------
class CurriculumEnv(gym.Env):
    """An AnimalAIEnv (with the run's training shaping) whose every episode the sampler actor assigns."""

    _made = 0  # environments made in this process: numbers them within an EnvRunner

    def __init__(self, env_config):
        import ray

        from aaai.env import AnimalAIEnv

        config = env_config["aaai_config"]
        self.env = AnimalAIEnv(config=env_part(config, config.train.reward_shaping))
        self.observation_space, self.action_space = self.env.observation_space, self.env.action_space
        self.sampler = ray.get_actor(env_config["sampler"])
        runner = getattr(env_config, "worker_index", 0)
        self.worker = runner * 1000 + CurriculumEnv._made
        CurriculumEnv._made += 1
        self.assigned: tuple[int, int, int] | None = None
        self.episode_return, self.shaping, self.length = 0.0, 0.0, 0

    def reset(self, *, seed=None, options=None):
        import ray

        level: int
        difficulty: int
        episode_seed: int
        level, difficulty, episode_seed = ray.get(self.sampler.sample.remote())  # RLlib's seed is not used
        self.assigned = (level, difficulty, episode_seed)
        self.episode_return, self.shaping, self.length = 0.0, 0.0, 0
        return self.env.reset(seed=episode_seed, options={"level": level, "difficulty": difficulty})

    def step(self, action):
        import ray

        observation, reward, terminated, truncated, info = self.env.step(action)
        self.episode_return += float(reward)
        self.shaping += float(info["reward_terms"]["shaping"])
        self.length += 1
        if terminated or truncated:
            assert self.assigned is not None, "reset() assigns the episode's cell before any step"
            level, difficulty, seed = self.assigned
            episode = Episode(
                self.worker,
                level,
                difficulty,
                seed,
                self.episode_return,
                self.episode_return - self.shaping,
                self.length,
                **{key: _plain(info[key]) for key in EPISODE_INFO_KEYS},
            )
            ray.get(self.sampler.record.remote(asdict(episode)))  # recorded before the next reset samples
        return observation, reward, terminated, truncated, info

    def close(self):
        self.env.close()


def _plain(value):
    return value.item() if isinstance(value, np.generic) else value


def make_env(env_config) -> CurriculumEnv:
    return CurriculumEnv(env_config)


def flatten_observations(env: Any, spaces: Any = None, device: Any = None) -> Any:
    """The EnvRunners' env-to-module connector (RLlib calls it with the env, its spaces and the device)."""
    from ray.rllib.connectors.env_to_module import FlattenObservations

    return FlattenObservations()


# --- the algorithm --------------------------------------------------------------------------
def ppo_config(config: Config, sampler: str, env_runners: int):
    """RLlib's PPOConfig from the run's train section (the stable-baselines3 learner's settings where
    RLlib has them: one iteration = n_steps per environment, minibatches of batch_size, n_epochs,
    lr, gamma, GAE lambda, entropy coefficient, two hidden layers of net_width; no KL term, clip 0.2,
    gradient norm 0.5, as stable-baselines3)."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    train = config.train
    num_envs = train.num_envs
    per_runner = max(1, math.ceil(num_envs / max(1, env_runners)))
    width = train.net_width
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config={"aaai_config": config, "sampler": sampler})
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=per_runner,
            rollout_fragment_length="auto",
            env_to_module_connector=flatten_observations,
        )
        .learners(num_learners=0)
        .training(
            train_batch_size_per_learner=train.n_steps * num_envs,
            minibatch_size=train.batch_size,
            num_epochs=train.n_epochs,
            lr=train.learning_rate,
            gamma=train.gamma,
            lambda_=train.gae_lambda,
            entropy_coeff=train.ent_coef,
            use_kl_loss=False,
            clip_param=0.2,
            vf_loss_coeff=0.5,
            vf_clip_param=math.inf,
            grad_clip=0.5,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[width, width], vf_share_layers=False))
        # An EnvRunner that dies (its node lost, its process killed) is replaced and training goes on.
        .fault_tolerance(restart_failed_env_runners=True, max_num_env_runner_restarts=MAX_RUNNER_RESTARTS)
        .debugging(seed=train.seed)
    )


@contextmanager
def _trainable_logdir(folder: str):
    """An Algorithm built outside Tune makes a log folder (unused here, left empty) in ~/ray_results;
    while this is open it makes it in ``folder`` instead (which the caller removes)."""
    from ray.tune.trainable import trainable

    default = getattr(trainable, "DEFAULT_STORAGE_PATH", None)
    trainable.DEFAULT_STORAGE_PATH = folder
    try:
        yield
    finally:
        if default is None:
            del trainable.DEFAULT_STORAGE_PATH
        else:
            trainable.DEFAULT_STORAGE_PATH = default


def _sampled(result: dict) -> int:
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED

    return int(result.get(ENV_RUNNER_RESULTS, {}).get(NUM_ENV_STEPS_SAMPLED, 0))


def _train_loop(
    algo,
    actor,
    tracker: Tracker,
    config: Config,
    checkpoint: Path | None,
    start_step: int,
    progress: Callable[[int], None],
) -> int:
    import ray

    from aaai.scoring.rllib_checkpoints import sign_checkpoint

    if checkpoint is not None:
        algo.restore_from_path(str((checkpoint / CHECKPOINT_FOLDER).absolute()))

    def save_model(model_zip) -> None:  # the Algorithm checkpoint, signed as this machine's
        algo.save_to_path(str((Path(model_zip).parent / CHECKPOINT_FOLDER).absolute()))  # pyarrow wants a URI
        sign_checkpoint(Path(model_zip).parent / CHECKPOINT_FOLDER)

    agent_state = lambda: {"backend": "rllib"}  # noqa: E731 - the model's state is the rllib/ folder
    step, total = start_step, config.train.total_steps
    while step < total and not tracker.out_of_time():
        result = algo.train()
        sampled = _sampled(result)
        if sampled <= 0:
            raise RuntimeError(f"an RLlib training iteration reported no sampled steps (result keys: {sorted(result)})")
        step += sampled
        finished = [Episode(**episode) for episode in ray.get(actor.collect.remote())]
        tracker.update(step, finished, agent_state, save_model=save_model)
        progress(sampled)
    tracker.save(step, agent_state, save_model=save_model, final=True)
    return step


def train_rllib(
    run_dir: str | Path,
    config: Config | None = None,
    resume: bool = False,
    total_steps: int | None = None,
    address: str | None = None,
    env_runners: int | None = None,
    progress: Callable[[int], None] | None = None,
    say: Callable[[str], None] = print,
    trust: bool = False,
) -> TrainResult:
    """:func:`aaai.train.training.train` with RLlib PPO: starts a run in ``run_dir`` with ``config`` (a
    resolved config) or resumes the run there (``total_steps`` moves its end, as in ``train``).

    ``address``: None starts a local Ray (``env_runners`` + 1 CPUs) for this call and stops it after;
    an address joins that cluster. ``env_runners``: RLlib EnvRunner processes (default
    ``train.processes``, see :func:`aaai.train.vector.worker_processes`; the ``train.num_envs``
    environments are shared out over them; 0 samples in this process), all sharing the one
    sampler actor. ``progress(n)`` is told the environment steps of each iteration. The run
    folder is locked for the whole call, as in ``train``.
    """
    from aaai.scoring.rllib_checkpoints import signing_key

    run = RunFolder(run_dir)
    check_writable(run.path, "--resume" if resume else "--run", folder=True)
    signing_key()  # the key that signs every checkpoint: made, or refused naming the fix, before any work
    with run.locked("--resume" if resume else "--run"):
        return _train_rllib(run, config, resume, total_steps, address, env_runners, progress, say, trust)


def _train_rllib(
    run: RunFolder,
    config: Config | None,
    resume: bool,
    total_steps: int | None,
    address: str | None,
    env_runners: int | None,
    progress: Callable[[int], None] | None,
    say: Callable[[str], None],
    trust: bool = False,
) -> TrainResult:
    """:func:`train_rllib` in its locked run folder (``trust``: its checkpoint loads unsigned, --trust-model)."""
    from aaai.scoring.ray_session import RaySession

    checkpoint = state = None
    if resume:
        config = load_config(run.read_config())
        point = run.resume_point(needs_model=False, say=say)
        if point is not None:
            checkpoint, state = point
            if state.get("agent", {}).get("backend") != "rllib" or not (checkpoint / CHECKPOINT_FOLDER).is_dir():
                raise ConfigError(
                    f"--resume: {str(checkpoint)!r} is not a checkpoint of an RLlib run "
                    f"(no {CHECKPOINT_FOLDER}/ beside state.json)"
                )
            from aaai.scoring.rllib_checkpoints import check_rllib_checkpoint

            check_rllib_checkpoint(checkpoint / CHECKPOINT_FOLDER, trust)  # pickles: signed here, or --trust-model
        if total_steps is not None:
            config = move_end(run, config, checkpoint, state, total_steps)
    else:
        if config is None:
            raise ConfigError(
                "train_rllib: a new run needs a config (aaai.config.load_config); a resumed one reads its own"
            )
        if config.train.agent != "ppo":
            raise ConfigError(
                f"config key 'train.agent': got {config.train.agent!r}; allowed with the rllib backend: ppo"
            )
        config = with_proprioception(config)
        check_trainable(config)
        if config.sensors.camera:
            raise ConfigError(
                "config key 'sensors.camera': got true; allowed with the rllib backend: false "
                "(FlattenObservations feeds an MLP; no CNN encoder is set up)"
            )
        run.create(config)
    env_runners = worker_processes(config.train) if env_runners is None else env_runners
    start_step = state["step"] if state else 0
    if resume:  # the log back to what the checkpoint counted: to its header if there was none
        run.trim_episodes(start_step)
    progress = progress or (lambda steps: None)

    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # the learner in this process; the EnvRunners need the other cores
    logdir = tempfile.mkdtemp(prefix="aaai-rllib-")
    try:
        with RaySession(address, workers=env_runners + 1):
            import ray
            from ray.tune.registry import register_env

            register_env(ENV_NAME, make_env)
            actor, name = start_curriculum_actor(config, state["curriculum"] if state else None)
            try:
                curriculum = CurriculumProxy(actor, config)
                tracker = Tracker(
                    run, curriculum, config, start_step, seconds=float(state.get("seconds", 0.0)) if state else 0.0
                )
                check_budget_left(run, config, tracker)
                with _trainable_logdir(logdir):
                    algo = ppo_config(config, name, env_runners).build_algo()
                try:
                    step = _train_loop(algo, actor, tracker, config, checkpoint, start_step, progress)
                    curriculum.write_heatmap(run.path / "curriculum.png")
                finally:
                    algo.stop()
            finally:
                ray.kill(actor)
    finally:
        torch.set_num_threads(threads)
        shutil.rmtree(logdir, ignore_errors=True)
    return TrainResult(run, step, tracker.episodes, start_step)
