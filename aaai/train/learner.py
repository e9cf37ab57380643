"""PPO from stable-baselines3 on the curriculum's parallel workers (needs the `train` extra)."""

from __future__ import annotations

from collections import deque
from pathlib import Path
from typing import Any, Callable

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv, VecMonitor

from aaai.config import Config
from aaai.scoring.model_config import save_model
from aaai.scoring.runs import Episode, RunFolder
from aaai.train.curriculum import episode_passed
from aaai.train.vector import CurriculumVecEnv


class CurriculumSB3Env(VecEnv):
    """Presents a CurriculumVecEnv to stable-baselines3 and keeps the episodes it finishes."""

    def __init__(self, vec: CurriculumVecEnv):
        self.vec = vec  # first: the base class asks the workers for their render_mode
        super().__init__(vec.num_envs, vec.single_observation_space, vec.single_action_space)
        self.finished: list[Episode] = []
        self._actions = None

    def reset(self):
        return self.vec.reset()

    def step_async(self, actions):
        self._actions = actions

    def step_wait(self):
        observation, rewards, terminated, truncated, finished, final = self.vec.step(self._actions)
        self.finished.extend(finished)
        dones = np.logical_or(terminated, truncated)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for i, last in final.items():
            infos[i] = {"terminal_observation": last, "TimeLimit.truncated": bool(truncated[i] and not terminated[i])}
        return observation, rewards.astype(np.float32), dones, infos

    def close(self):
        self.vec.close()

    def get_attr(self, attr_name, indices=None):
        values = self.vec.envs.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name, value, indices=None):
        raise NotImplementedError("the workers' attributes are fixed by the config")

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        values = self.vec.envs.call(method_name, *method_args, **method_kwargs)
        return [values[i] for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False for _ in self._get_indices(indices)]


class TrackerCallback(BaseCallback):
    """Hands finished episodes to the tracker and logs to TensorBoard what the shaped
    ``rollout/ep_rew_mean`` does not show: over the last ``recent`` episodes the task return
    (``rollout/task_return_mean``, without shaping: what the scoreboard counts), the food eaten
    and the pass rate (return >= 0.8 x max reward); the pass rate per cell over the curriculum's
    window (``cells/pass_rate_L<level>_d<difficulty>``) and the sampler's p per cell."""

    def __init__(
        self,
        env: CurriculumSB3Env,
        tracker,
        progress: Callable[[int], None],
        recent: int = 100,
        config: Config | None = None,
    ):
        super().__init__()
        self.env, self.tracker, self.progress, self.config = env, tracker, progress, config
        self.recent: deque[Episode] = deque(maxlen=recent)

    def save(self, path: Path) -> None:
        """The model file, carrying the run's config when there is one (a model file is scored alone)."""
        if self.config is None:
            self.model.save(path)
        else:
            save_model(self.model, path, self.config)

    def _on_step(self) -> bool:
        finished, self.env.finished = self.env.finished, []
        self.tracker.update(self.num_timesteps, finished, agent_state=dict, save_model=self.save)
        self.progress(self.env.num_envs)
        if finished:
            self.recent.extend(finished)
            self.logger.record("rollout/task_return_mean", float(np.mean([e.task_return for e in self.recent])))
            self.logger.record("rollout/food_eaten_mean", float(np.mean([e.food_eaten for e in self.recent])))
            self.logger.record(
                "rollout/pass_rate", float(np.mean([episode_passed(e.task_return, e.max_reward) for e in self.recent]))
            )
            curriculum = self.tracker.curriculum
            for (level, difficulty), p, q in zip(curriculum.cells, curriculum.probabilities(), curriculum.pass_rates()):
                self.logger.record(f"curriculum/p_L{level}_d{difficulty}", float(p))
                if np.isfinite(q):
                    self.logger.record(f"cells/pass_rate_L{level}_d{difficulty}", float(q))
        return not self.tracker.out_of_time()  # train.max_minutes spent: learn() stops here


def ppo_from_config(env, config: Config, run: RunFolder) -> PPO:
    """PPO from the run's config; RecurrentPPO when it starts from a recurrent student (--init-from)."""
    train = config.train
    width = train.net_width
    algorithm: Any = PPO
    policy, kwargs = "MultiInputPolicy", {"net_arch": [width, width], "log_std_init": train.log_std_init}
    if train.init_from:
        from aaai.train import recurrent_student

        if recurrent_student.is_recurrent(model_path(train.init_from)):
            from sb3_contrib import RecurrentPPO

            algorithm, policy = RecurrentPPO, recurrent_student.POLICY
            kwargs = recurrent_student.policy_kwargs(width, train.log_std_init)
    return algorithm(
        policy,
        env,
        learning_rate=train.learning_rate,
        n_steps=train.n_steps,
        batch_size=train.batch_size,
        n_epochs=train.n_epochs,
        gamma=train.gamma,
        gae_lambda=train.gae_lambda,
        ent_coef=train.ent_coef,
        policy_kwargs=kwargs,
        tensorboard_log=str(run.path / "tb"),
        seed=train.seed,
        device="cpu",
        verbose=0,
    )


def lean_torch() -> None:
    """The learner process's torch settings, which change nothing that is learned: one thread (the
    workers need the other cores; small networks gain nothing from more), and no argument checks
    in torch.distributions (PyTorch's documented switch; stable-baselines3 builds a new Normal at
    every step, and its checks cost about a tenth of a forward pass on a small batch)."""
    torch.set_num_threads(1)
    torch.distributions.Distribution.set_default_validate_args(False)


def train_ppo(
    vec: CurriculumVecEnv,
    tracker,
    config: Config,
    run: RunFolder,
    checkpoint: Path | None,
    progress: Callable[[int], None],
    trust: bool = False,
) -> int:
    lean_torch()
    env = CurriculumSB3Env(vec)
    monitored = VecMonitor(env)
    if checkpoint is not None:
        from aaai.scoring.model_io import load_for_training  # without unpickling, unless train --trust-model

        width = config.train.net_width
        model = load_for_training(
            checkpoint / "model.zip",
            monitored,
            tensorboard_log=str(run.path / "tb"),
            fallback_kwargs={"net_arch": [width, width], "log_std_init": config.train.log_std_init},
            trust=trust,
        )
    else:
        model = ppo_from_config(monitored, config, run)
        if config.train.init_from:
            start_from(model, config.train.init_from)
    callbacks: list[BaseCallback] = [TrackerCallback(env, tracker, progress, config=config)]
    if config.train.value_warmup_steps or config.train.bc_coef:  # from a student's weights (docs: Training)
        from aaai.train.finetune import anchor_from_config

        student = student_weights(config.train.init_from) if config.train.bc_coef and config.train.init_from else None
        anchor = anchor_from_config(config, student)
        if anchor is not None:
            callbacks.append(anchor)
    remaining = config.train.total_steps - model.num_timesteps
    if remaining > 0:
        model.learn(
            remaining,
            callback=callbacks,
            reset_num_timesteps=checkpoint is None,
            tb_log_name="ppo",
        )
    tracker.save(model.num_timesteps, dict, save_model=lambda path: save_model(model, path, config), final=True)
    return model.num_timesteps


def start_from(model: PPO, source: str | Path) -> None:
    """Loads the policy weights of ``source`` (a run folder's newest model, or a model .zip; e.g. a
    student of the reference) into a fresh PPO model; only the weights file is read, with
    ``torch.load(weights_only=True)``, so nothing in it can run. Refused, naming both, when the
    networks differ (another action mode, senses or net_width)."""
    from aaai.config import ConfigError

    path = model_path(source)
    weights = student_weights(path)
    own = model.policy.state_dict()
    differ = sorted(
        k for k in set(own) | set(weights) if k not in own or k not in weights or own[k].shape != weights[k].shape
    )
    if differ:
        raise ConfigError(
            f"--init-from: the network of {str(path)!r} does not fit this run's (first difference: "
            f"{differ[0]}: {tuple(weights[differ[0]].shape) if differ[0] in weights else 'missing'} there, "
            f"{tuple(own[differ[0]].shape) if differ[0] in own else 'missing'} here); allowed: a model "
            "trained with the same action mode, senses and train.net_width"
        )
    model.policy.load_state_dict(weights)


def model_path(source: str | Path) -> Path:
    """The model file ``source`` names: a run folder's newest model, or the model .zip itself."""
    from aaai.config import ConfigError

    path = Path(source)
    if path.is_dir():
        newest = RunFolder(path).latest_checkpoint()
        if newest is None:
            raise ConfigError(
                f"--init-from: run folder {str(source)!r} holds no model (final/ or checkpoints/*/model.zip)"
            )
        path = newest / "model.zip"
    return path


def student_weights(source: str | Path) -> dict:
    """The policy weights of ``source`` (:func:`model_path`), read as data: only the weights file,
    with ``torch.load(weights_only=True)``, within the model files' budgets."""
    from aaai.config import ConfigError
    from aaai.scoring.model_archive import read_tensors

    try:
        return read_tensors(model_path(source), "policy.pth", trust_helps=False)  # budgets, weights_only, finite
    except ConfigError as error:
        raise ConfigError(f"--init-from: {error}") from None
