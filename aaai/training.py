"""`aaai train`: a curriculum (or uniform) over (level, difficulty) cells feeding parallel workers.

The learner is PPO from stable-baselines3 (aaai/learner.py, the `train` extra); ``agent:
random`` runs the same loop with uniform random actions and no torch.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from aaai.config import ConfigError, load_config
from aaai.curriculum import Curriculum
from aaai.runs import RunFolder, check_writable
from aaai.vector import CurriculumVecEnv, Episode

MIN_CNN_RESOLUTION = 36  # the smallest image stable-baselines3's NatureCNN accepts


@dataclass
class TrainResult:
    run: RunFolder
    steps: int
    episodes: int
    resumed_from: int


class Tracker:
    """Logs finished episodes and writes heatmaps and checkpoints as the step count passes their marks."""

    def __init__(self, run: RunFolder, curriculum: Curriculum, config: dict, start_step: int):
        self.run, self.curriculum = run, curriculum
        self.checkpoint_every = config["train"]["checkpoint_every"]
        self.heatmap_every = config["train"]["heatmap_every"]
        self.next_checkpoint = (start_step // self.checkpoint_every + 1) * self.checkpoint_every
        self.next_heatmap = (start_step // self.heatmap_every + 1) * self.heatmap_every
        self.episodes = 0

    def update(self, step: int, finished: list[Episode], agent_state: Callable[[], dict],
               save_model: Callable[[Path], None] | None = None) -> None:
        if finished:
            self.run.log_episodes(step, finished)
            self.episodes += len(finished)
        if step >= self.next_heatmap:
            self.curriculum.write_heatmap(self.run.path / "curriculum.png")
            self.next_heatmap = (step // self.heatmap_every + 1) * self.heatmap_every
        if step >= self.next_checkpoint:
            self.save(step, agent_state, save_model)
            self.next_checkpoint = (step // self.checkpoint_every + 1) * self.checkpoint_every

    def save(self, step: int, agent_state: Callable[[], dict], save_model=None, final: bool = False) -> Path:
        state = {"curriculum": self.curriculum.state_dict(), "agent": agent_state()}
        return self.run.save_checkpoint(step, state, save_model, final=final)


PROPRIOCEPTION = ("joint_velocities", "head_orientation", "foot_contacts")


def with_proprioception(config: dict) -> dict:
    """The run's config with the extra body senses on when train.proprioception asks for them.

    The environment leaves them off by default; a learner without joint speeds, body tilt and foot
    contacts learned next to nothing on L0 in our runs (see the README), so training turns them on.
    The run folder's config records the result, and evaluation reads it from there.
    """
    if not config["train"]["proprioception"]:
        return config
    return load_config(config, sensors={name: True for name in PROPRIOCEPTION})


def check_trainable(config: dict) -> None:
    sensors = config["sensors"]
    if config["train"]["agent"] == "ppo" and sensors["camera"] and sensors["camera_resolution"] < MIN_CNN_RESOLUTION:
        raise ConfigError(
            f"config key 'sensors.camera_resolution': got {sensors['camera_resolution']}; allowed for PPO "
            f"training: {MIN_CNN_RESOLUTION} or more (the smallest image the CNN accepts)"
        )


def move_end(run: RunFolder, config: dict, checkpoint: Path | None, state: dict | None, total_steps: int) -> dict:
    """On resume: the run's config with its end moved to ``total_steps`` (recorded in the run
    folder); refused at or below the steps the run has done."""
    done = state["step"] if state else 0
    if total_steps <= done:
        where = f" ({checkpoint.relative_to(run.path)})" if checkpoint is not None else ""
        raise ConfigError(f"--steps: got {total_steps}; the run already has {done} steps{where}; "
                          f"allowed: more than {done}")
    config = load_config(config, total_steps=total_steps)
    run.update_config(config)
    return config


def train(run_dir: str | Path, config: dict | None = None, resume: bool = False,
          progress: Callable[[int], None] | None = None, asynchronous: bool | None = None,
          total_steps: int | None = None, say: Callable[[str], None] = print) -> TrainResult:
    """Starts a run in ``run_dir`` with ``config`` (a resolved config), or resumes the run there.

    A resume continues from the newest readable saved point (``final/`` included); a damaged one is
    skipped and ``say`` is told so. ``total_steps`` (if given) moves the run's end; the run
    folder's config records it. It may not fall below the steps already done.
    """
    run = RunFolder(run_dir)
    check_writable(run.path, "--resume" if resume else "--run", folder=True)  # before any work is done
    checkpoint = state = None
    if resume:
        config = load_config(run.read_config())
        point = run.resume_point(needs_model=config["train"]["agent"] == "ppo", say=say)
        if point is not None:
            checkpoint, state = point
        if total_steps is not None:
            config = move_end(run, config, checkpoint, state, total_steps)
    else:
        config = with_proprioception(config)
        check_trainable(config)  # before the run folder exists: a refused config leaves nothing behind
        run.create(config)
    curriculum = Curriculum.from_config(config)
    start_step = state["step"] if state else 0
    if state:
        curriculum.load_state_dict(state["curriculum"])
        run.trim_episodes(start_step)
    tracker = Tracker(run, curriculum, config, start_step)
    vec = CurriculumVecEnv(config, curriculum, config["train"]["num_envs"], asynchronous=asynchronous)
    progress = progress or (lambda steps: None)
    try:
        if config["train"]["agent"] == "random":
            steps = _train_random(vec, tracker, config, start_step, state, progress)
        else:
            from aaai.learner import train_ppo

            steps = train_ppo(vec, tracker, config, run, checkpoint, progress)
    finally:
        vec.close()
    curriculum.write_heatmap(run.path / "curriculum.png")
    return TrainResult(run, steps, tracker.episodes, start_step)


def _train_random(vec: CurriculumVecEnv, tracker: Tracker, config: dict, start_step: int,
                  state: dict | None, progress: Callable[[int], None]) -> int:
    rng = np.random.default_rng(config["train"]["seed"])
    if state:
        rng.bit_generator.state = state["agent"]["rng"]
    agent_state = lambda: {"rng": rng.bit_generator.state}  # noqa: E731
    shape = (vec.num_envs, *vec.single_action_space.shape)
    step, total = start_step, config["train"]["total_steps"]
    vec.reset()
    while step < total:
        _, _, _, _, finished, _ = vec.step(rng.uniform(-1.0, 1.0, shape).astype(np.float32))
        step += vec.num_envs
        tracker.update(step, finished, agent_state)
        progress(vec.num_envs)
    tracker.save(step, agent_state, final=True)
    return step
