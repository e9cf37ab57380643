"""`aaai train`: a curriculum (or uniform) over (level, difficulty) cells feeding parallel workers.

The learner is PPO from stable-baselines3 (aaai/train/learner.py, the `train` extra); ``agent:
random`` runs the same loop with uniform random actions and no torch.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from aaai.config import Config, ConfigError, load_config
from aaai.files import os_error_message
from aaai.jobs import Progress as JobProgress
from aaai.scoring.runs import RunFolder, check_writable
from aaai.train.curriculum import Curriculum, episode_passed
from aaai.train.vector import CurriculumVecEnv, Episode

MIN_CNN_RESOLUTION = 36  # the smallest image stable-baselines3's NatureCNN accepts


@dataclass
class TrainResult:
    run: RunFolder
    steps: int
    episodes: int
    resumed_from: int


class Progress(JobProgress):
    """A training run's progress (:class:`aaai.jobs.Progress`), told of its finished episodes."""

    def on_episodes(self, finished: list[Episode]) -> None:
        """For :class:`Tracker`: finished training episodes."""
        self.add_episodes([episode_passed(e.task_return, e.max_reward) for e in finished])


class CurriculumState(Protocol):
    """What the Tracker needs of a curriculum: a Curriculum, or the RLlib run's proxy of one in a Ray actor."""

    def state_dict(self) -> dict: ...

    def write_heatmap(self, path: Path) -> None: ...


class Tracker:
    """Logs finished episodes and writes heatmaps and checkpoints as the step count passes their marks.
    ``on_episodes`` (if set) is told of every finished episode too (a progress report). Each saved
    state records ``seconds``: the run's wall time of training so far, ``seconds`` (the time before
    the point it resumed from) plus the time since the tracker started. ``out_of_time`` tells the
    learner when that time has reached ``train.max_minutes`` (never, when it is 0)."""

    def __init__(
        self,
        run: RunFolder,
        curriculum: CurriculumState,
        config: Config,
        start_step: int,
        on_episodes: Callable[[list[Episode]], None] | None = None,
        seconds: float = 0.0,
    ):
        self.run, self.curriculum, self.on_episodes = run, curriculum, on_episodes
        self.seconds_before, self.started = seconds, time.perf_counter()
        self.checkpoint_every = config.train.checkpoint_every
        self.max_seconds = config.train.max_minutes * 60.0 if config.train.max_minutes > 0 else None
        self.heatmap_every = config.train.heatmap_every
        self.next_checkpoint = (start_step // self.checkpoint_every + 1) * self.checkpoint_every
        self.next_heatmap = (start_step // self.heatmap_every + 1) * self.heatmap_every
        self.episodes = 0

    def update(
        self,
        step: int,
        finished: list[Episode],
        agent_state: Callable[[], dict],
        save_model: Callable[[Path], None] | None = None,
    ) -> None:
        if finished:
            self.run.log_episodes(step, finished)
            self.episodes += len(finished)
            if self.on_episodes is not None:
                self.on_episodes(finished)
        if step >= self.next_heatmap:
            self.curriculum.write_heatmap(self.run.path / "curriculum.png")
            self.next_heatmap = (step // self.heatmap_every + 1) * self.heatmap_every
        if step >= self.next_checkpoint:
            self.save(step, agent_state, save_model)
            self.next_checkpoint = (step // self.checkpoint_every + 1) * self.checkpoint_every

    def seconds(self) -> float:
        """The run's wall time of training so far, over its resumes."""
        return self.seconds_before + time.perf_counter() - self.started

    def out_of_time(self) -> bool:
        """Has the run spent its budget of ``train.max_minutes``?"""
        return self.max_seconds is not None and self.seconds() >= self.max_seconds

    def save(self, step: int, agent_state: Callable[[], dict], save_model=None, final: bool = False) -> Path:
        seconds = round(self.seconds(), 1)
        state = {"curriculum": self.curriculum.state_dict(), "agent": agent_state(), "seconds": seconds}
        return self.run.save_checkpoint(step, state, save_model, final=final)


PROPRIOCEPTION = ("joint_velocities", "head_orientation", "foot_contacts")


def with_proprioception(config: Config) -> Config:
    """The run's config with the extra body senses on when train.proprioception asks for them.

    The environment leaves them off by default; a learner without joint speeds, body tilt and foot
    contacts learned next to nothing on L0 in our runs (see the docs, Training and curricula), so
    training turns them on.
    The run folder's config records the result, and evaluation reads it from there.
    """
    if not config.train.proprioception:
        return config
    return load_config(config, sensors={name: True for name in PROPRIOCEPTION})


def check_trainable(config: Config) -> None:
    """What a new run refuses before its folder exists (a resumed or scored run is read as it is)."""
    curriculum = config.curriculum
    if curriculum.mode == "random" and curriculum.sampler != "uniform":
        raise ConfigError(
            f"config key 'curriculum.sampler': got {curriculum.sampler!r} with 'curriculum.mode': random "
            "(--random), which samples cells uniformly; allowed: uniform with mode random, or mode curriculum"
        )
    sensors = config.sensors
    if config.train.agent == "ppo" and sensors.camera and sensors.camera_resolution < MIN_CNN_RESOLUTION:
        raise ConfigError(
            f"config key 'sensors.camera_resolution': got {sensors.camera_resolution}; allowed for PPO "
            f"training: {MIN_CNN_RESOLUTION} or more (the smallest image the CNN accepts)"
        )


def check_init_from(config: Config) -> None:
    """``train.init_from`` a run folder: its action mode, body, senses and network width must be this
    run's, or its weights cannot fit (a model .zip is checked when its weights are loaded)."""
    source = config.train.init_from
    if not source:
        return
    if config.train.agent != "ppo":
        raise ConfigError("--init-from: only a PPO run starts from another's weights (train.agent: ppo)")
    path = Path(source)
    if not path.exists():
        raise ConfigError(f"--init-from: {source!r} does not exist; allowed: a run folder or a model .zip")
    if path.is_dir():
        _check_init_run(config, source, path)
        newest = RunFolder(path).latest_checkpoint()
        if newest is None:
            raise ConfigError(f"--init-from: run folder {source!r} holds no model (final/ or checkpoints/*/model.zip)")
        path = newest / "model.zip"
    elif not path.is_file():  # a pipe would wait for a writer, a device never end
        raise ConfigError(f"--init-from: {source!r} is a device or a pipe; allowed: a run folder or a model .zip")
    check_init_weights(config, path)


def check_init_weights(config: Config, path: Path) -> None:
    """The --init-from model's weights, read as start_from reads them and checked against this run's
    network, before the run folder exists (a bad model leaves nothing behind)."""
    from aaai.env import AnimalAIEnv
    from aaai.scoring.model_io import check_start_weights
    from aaai.train import recurrent_student

    env = AnimalAIEnv(config=config)
    try:
        width = config.train.net_width
        kwargs = {"net_arch": [width, width], "log_std_init": config.train.log_std_init}
        if recurrent_student.is_recurrent(path):  # a recurrent student: fine-tuned by RecurrentPPO
            kwargs = recurrent_student.policy_kwargs(width, config.train.log_std_init)
        check_start_weights(path, env.observation_space, env.action_space, kwargs, config)
    except ConfigError as error:
        raise ConfigError(f"--init-from: {error}") from None
    finally:
        env.close()


def _check_init_run(config: Config, source: str, path: Path) -> None:
    theirs = load_config(RunFolder(path).read_config())
    keys = ["agent.action_mode", "agent.body", "train.net_width"] + [
        f"sensors.{field.name}" for field in dataclasses.fields(config.sensors)
    ]
    there, here = theirs.flat(), config.flat()  # the keys compared by their dotted names, as the message says
    differ = [f"{key}: {there[key]!r} there, {here[key]!r} here" for key in keys if there[key] != here[key]]
    if differ:
        raise ConfigError(
            f"--init-from: run {source!r} was trained with another env or network ({'; '.join(differ)}); "
            "allowed: a run of the same action mode, body, senses and train.net_width"
        )


def move_end(run: RunFolder, config: Config, checkpoint: Path | None, state: dict | None, total_steps: int) -> Config:
    """On resume: the run's config with its end moved to ``total_steps`` (recorded in the run
    folder); refused at or below the steps the run has done."""
    done = state["step"] if state else 0
    if total_steps <= done:
        where = f" ({checkpoint.relative_to(run.path)})" if checkpoint is not None else ""
        raise ConfigError(
            f"--steps: got {total_steps}; the run already has {done} steps{where}; allowed: more than {done}"
        )
    config = load_config(config, total_steps=total_steps)
    run.update_config(config)
    return config


def check_budget_left(run: RunFolder, config: Config, tracker: Tracker) -> None:
    """On resume: a run that has spent its ``train.max_minutes`` is done (ConfigError saying so)."""
    if tracker.out_of_time():
        raise ConfigError(
            f"--resume: the run {run.path} has trained {tracker.seconds_before:.0f} s, its whole budget of "
            f"train.max_minutes {config.train.max_minutes:g} ({config.train.max_minutes * 60:.0f} s): it is done, "
            f"its model in {run.path / 'final'}; allowed: a new run (aaai train --init-from {run.path} to go on "
            "from its weights)"
        )


def write_failure(error: OSError, run_dir: str | Path | None) -> str:
    """One line for an OS error while training (a full disk, a permission taken away): the file,
    the cause, and that the run resumes from its last checkpoint."""
    where = f" --resume {run_dir}" if run_dir else ""
    return (
        f"{os_error_message(error)}. The run keeps what its last checkpoint saved: free the space or fix "
        f"the permission, then run aaai train{where}"
    )


def train(
    run_dir: str | Path,
    config: Config | None = None,
    resume: bool = False,
    progress: Callable[[int], None] | None = None,
    asynchronous: bool | None = None,
    total_steps: int | None = None,
    say: Callable[[str], None] = print,
    on_episodes: Callable[[list[Episode]], None] | None = None,
    trust: bool = False,
) -> TrainResult:
    """Starts a run in ``run_dir`` with ``config`` (a resolved config), or resumes the run there.

    A resume continues from the newest readable saved point (``final/`` included); a damaged one is
    skipped and ``say`` is told so. ``total_steps`` (if given) moves the run's end; the run
    folder's config records it. It may not fall below the steps already done. ``progress`` is told
    of every step, ``on_episodes`` of every finished episode (e.g. :class:`Progress`). ``trust``
    (``--trust-model``): a resumed model file is loaded with code from it.

    The run folder is locked for the whole call (:meth:`RunFolder.locked`): another process
    training or resuming it is refused at once, naming this one's pid.
    """
    run = RunFolder(run_dir)
    check_writable(run.path, "--resume" if resume else "--run", folder=True)  # before any work is done
    if not resume:
        if config is None:
            raise ConfigError("train: a new run needs a config (aaai.config.load_config); a resumed one reads its own")
        config = with_proprioception(config)
        check_trainable(config)  # before the run folder exists: a refused config leaves nothing behind
        check_init_from(config)
        if config.train.value_warmup_steps or config.train.bc_coef:  # a fine-tune of a student (torch)
            from aaai.train.finetune import check_finetune

            check_finetune(config)
    with run.locked("--resume" if resume else "--run"):
        return _train(run, config, resume, progress, asynchronous, total_steps, say, on_episodes, trust)


def _train(
    run: RunFolder,
    config: Config | None,
    resume: bool,
    progress: Callable[[int], None] | None,
    asynchronous: bool | None,
    total_steps: int | None,
    say: Callable[[str], None],
    on_episodes: Callable[[list[Episode]], None] | None,
    trust: bool = False,
) -> TrainResult:
    """:func:`train` in its locked run folder (a new run's config checked)."""
    checkpoint = state = None
    if resume:
        config = load_config(run.read_config())
        point = run.resume_point(needs_model=config.train.agent == "ppo", say=say)
        if point is not None:
            checkpoint, state = point
        if total_steps is not None:
            config = move_end(run, config, checkpoint, state, total_steps)
    else:
        assert config is not None, "train() refuses a new run without a config"
        run.create(config)
    curriculum = Curriculum.from_config(config)
    start_step = state["step"] if state else 0
    if state:
        curriculum.load_state_dict(state["curriculum"])
    if resume:  # the log back to what the checkpoint counted: to its header if there was none
        run.trim_episodes(start_step)
    tracker = Tracker(
        run, curriculum, config, start_step, on_episodes, float(state.get("seconds", 0.0)) if state else 0.0
    )
    check_budget_left(run, config, tracker)
    vec = CurriculumVecEnv(config, curriculum, config.train.num_envs, asynchronous=asynchronous)
    progress = progress or (lambda steps: None)
    try:
        if config.train.agent == "random":
            steps = _train_random(vec, tracker, config, start_step, state, progress)
        else:
            from aaai.train.learner import train_ppo

            steps = train_ppo(vec, tracker, config, run, checkpoint, progress, trust)
    finally:
        vec.close()
    curriculum.write_heatmap(run.path / "curriculum.png")
    return TrainResult(run, steps, tracker.episodes, start_step)


def _train_random(
    vec: CurriculumVecEnv,
    tracker: Tracker,
    config: Config,
    start_step: int,
    state: dict | None,
    progress: Callable[[int], None],
) -> int:
    rng = np.random.default_rng(config.train.seed)
    if state:
        rng.bit_generator.state = state["agent"]["rng"]
    agent_state = lambda: {"rng": rng.bit_generator.state}  # noqa: E731
    action_shape = vec.single_action_space.shape
    assert action_shape is not None, "a Box action space has a shape"
    shape = (vec.num_envs, *action_shape)
    step, total = start_step, config.train.total_steps
    vec.reset()
    while step < total and not tracker.out_of_time():
        _, _, _, _, finished, _ = vec.step(rng.uniform(-1.0, 1.0, shape).astype(np.float32))
        step += vec.num_envs
        tracker.update(step, finished, agent_state)
        progress(vec.num_envs)
    tracker.save(step, agent_state, final=True)
    return step
