"""PPO from a student's weights that does not undo the student at its first updates
(``aaai train --init-from RUN`` with ``train.value_warmup_steps`` and ``train.bc_coef``;
configs/student_ppo.yaml; docs: Training, Reinforcing the student).

A student of the reference (aaai.train.student) is fitted by regression of its mean action: its value
head was never trained. PPO started from it computes its first advantages from that random value
head, and its first updates push the policy along noise. Two pieces, both one stable-baselines3
callback (:class:`StudentAnchor`) on the ordinary PPO model, so that a checkpoint is an ordinary
model file:

1. **Value warm-up.** The rollouts that start before ``train.value_warmup_steps`` decisions are played
   by the student (its own actions, at its own exploration), their returns computed as PPO computes
   them (``train.gamma``, ``train.gae_lambda``), and their updates fit the value head only, for
   ``train.value_warmup_epochs`` passes each: every parameter outside the value head is frozen while
   they run, so the policy's outputs do not move.
2. **The anchor.** After the warm-up, PPO's loss gains ``w x KL(student || policy)``, the KL divergence
   from the student's action distribution (the frozen weights it started from) to the policy's, on
   each minibatch's observations; ``w`` starts at ``train.bc_coef`` and falls linearly to 0 over
   ``train.bc_decay_steps`` decisions. The term rides on PPO's own loss (:class:`_AddLoss`), so the
   gradient clipping and the optimiser see one loss, as if it were written in PPO's ``train()``.

Logged to TensorBoard: ``train/value_error`` (every rollout: the mean squared error of the value head
on the returns of the rollout just played, before the update; it falls during the warm-up),
``train/value_warmup`` (1 for a warm-up update), ``train/bc_coef`` and ``train/bc_kl`` (the anchor's
weight and the KL it weighs, mean over the update's minibatches).

RecurrentPPO (sb3-contrib): the warm-up works on its policies as they are (the value head's
parameters are named by :data:`VALUE_PARTS`, its LSTM of the critic included); the anchor refuses a
recurrent policy for now: the student's distribution there needs the student's own memory along each
sequence, which the rollout does not keep.
"""

from __future__ import annotations

import copy
from typing import Any

import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.distributions import sum_independent_dims

from aaai.config import Config, ConfigError

# The parameters of a stable-baselines3 (or sb3-contrib recurrent) actor-critic policy that belong
# to the value only, by the start of their names; everything else is frozen in a warm-up update.
VALUE_PARTS = ("value_net.", "mlp_extractor.value_net.", "vf_features_extractor.", "lstm_critic.", "critic.")


def check_finetune(config: Config) -> None:
    """The warm-up and the anchor need a policy to start from (``train.init_from``); refused before
    the run folder exists (ConfigError). Called only when one is asked for (this module imports torch)."""
    train = config.train
    for key, value, off in (("value_warmup_steps", train.value_warmup_steps, 0), ("bc_coef", train.bc_coef, 0.0)):
        if value != off and not train.init_from:
            raise ConfigError(
                f"config key 'train.{key}': got {value!r} for a run that starts from no policy; allowed: "
                f"{off!r}, or a run started from a student's weights (--init-from RUN, train.init_from)"
            )


def bc_weight(step: int, coef: float, warmup_steps: int, decay_steps: int) -> float:
    """The anchor's weight at ``step`` decisions: ``coef`` at the end of the warm-up, falling
    linearly to 0 at ``decay_steps`` decisions after it, and 0 from there on."""
    done = max(step - warmup_steps, 0)
    if coef <= 0 or done >= decay_steps:
        return 0.0
    return coef * (1.0 - done / decay_steps)


def value_parameters(policy) -> set[str]:
    """The names of ``policy``'s parameters that belong to the value head only (:data:`VALUE_PARTS`)."""
    return {name for name, _ in policy.named_parameters() if name.startswith(VALUE_PARTS)}


class _AddLoss(torch.autograd.Function):
    """``values`` unchanged on the way forward; on the way back, ``term`` receives the gradient
    ``weight``, so that the loss PPO builds from ``values`` behaves as ``loss + weight x term``."""

    @staticmethod
    def forward(ctx: Any, values: torch.Tensor, term: torch.Tensor, weight: float) -> torch.Tensor:
        ctx.weight = weight
        return values.clone()

    @staticmethod
    def backward(ctx: Any, *grads: torch.Tensor) -> Any:
        (grad,) = grads
        return grad, torch.tensor(ctx.weight, dtype=grad.dtype), None


class StudentAnchor(BaseCallback):
    """The value warm-up and the decaying anchor to the student, as one callback of ``model.learn``.

    ``student`` is the student's policy weights (a state dict of the model's policy), needed when
    ``bc_coef`` > 0; ``warmup_steps``, ``warmup_epochs``, ``bc_coef``, ``decay_steps`` are the
    ``train.*`` keys of the same names (:func:`anchor_from_config`)."""

    def __init__(
        self,
        student: dict | None,
        warmup_steps: int = 0,
        warmup_epochs: int = 10,
        bc_coef: float = 0.0,
        decay_steps: int = 100000,
    ):
        super().__init__()
        if bc_coef > 0 and student is None:
            raise ConfigError("config key 'train.bc_coef': the anchor needs the student's weights (train.init_from)")
        self.student, self.warmup_steps, self.warmup_epochs = student, warmup_steps, warmup_epochs
        self.bc_coef, self.decay_steps = bc_coef, decay_steps
        self.weight = 0.0  # the anchor's weight in the coming update
        self.frozen: Any = None  # the student's policy, frozen
        self._n_epochs: int | None = None  # PPO's own, while a warm-up update changes it
        self._held: list = []  # parameters frozen for a warm-up update
        self._evaluate: Any = None  # the policy's own evaluate_actions, while the anchor wraps it

    @property
    def _ppo(self) -> Any:
        """The model trained: PPO (or RecurrentPPO), with its rollout buffer and epochs."""
        return self.model

    # --- the callback's hooks ---------------------------------------------------------------
    def _on_training_start(self) -> None:
        policy = self._ppo.policy
        if self.warmup_steps and not value_parameters(policy):
            raise ConfigError(
                f"config key 'train.value_warmup_steps': got {self.warmup_steps} for a policy without a value "
                "head of its own (no parameter named as VALUE_PARTS lists); allowed: 0 with this policy"
            )
        if self.bc_coef > 0:
            if hasattr(policy, "lstm_actor"):  # sb3-contrib's RecurrentActorCriticPolicy
                raise ConfigError(
                    "config key 'train.bc_coef': the anchor to the student is not built for recurrent "
                    "policies yet; allowed: 0 with a recurrent policy"
                )
            self.frozen = copy.deepcopy(policy)
            self.frozen.load_state_dict(self.student)
            self.frozen.set_training_mode(False)
            for parameter in self.frozen.parameters():
                parameter.requires_grad_(False)
            self._evaluate = policy.evaluate_actions
            setattr(policy, "evaluate_actions", self._anchored)  # an instance attribute: not saved with the model

    def _on_rollout_start(self) -> None:
        self._release()
        self._rollout_start = self._ppo.num_timesteps

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        buffer = self._ppo.rollout_buffer
        self.logger.record("train/value_error", float(((buffer.returns - buffer.values) ** 2).mean()))
        warming = self._rollout_start < self.warmup_steps
        self.logger.record("train/value_warmup", int(warming))
        step = self._ppo.num_timesteps
        self.weight = 0.0 if warming else bc_weight(step, self.bc_coef, self.warmup_steps, self.decay_steps)
        if self.bc_coef > 0:
            self.logger.record("train/bc_coef", self.weight)
        if warming:
            self._hold()

    def _on_training_end(self) -> None:
        self._release()
        if self._evaluate is not None:
            del self._ppo.policy.evaluate_actions  # the policy's own method again
            self._evaluate = None

    # --- the two pieces -----------------------------------------------------------------------
    def _hold(self) -> None:
        """Freezes every parameter outside the value head and sets the warm-up's epochs, for one update."""
        values = value_parameters(self._ppo.policy)
        self._held = [p for name, p in self._ppo.policy.named_parameters() if name not in values and p.requires_grad]
        for parameter in self._held:
            parameter.requires_grad_(False)
        self._n_epochs, self._ppo.n_epochs = self._ppo.n_epochs, self.warmup_epochs

    def _release(self) -> None:
        """Undoes :meth:`_hold` (before anything is played or saved)."""
        for parameter in self._held:
            parameter.requires_grad_(True)
        self._held = []
        if self._n_epochs is not None:
            self._ppo.n_epochs, self._n_epochs = self._n_epochs, None

    def _anchored(self, observations, actions, *args, **kwargs):
        """The policy's evaluate_actions, with ``weight x KL(student || policy)`` on these observations
        added to PPO's loss through the values it returns."""
        values, log_prob, entropy = self._evaluate(observations, actions, *args, **kwargs)
        if self.weight <= 0:
            return values, log_prob, entropy
        distribution = self._ppo.policy.get_distribution(observations)
        with torch.no_grad():
            target = self.frozen.get_distribution(observations)
        kl = kl_divergence(target, distribution).mean()
        self.logger.record_mean("train/bc_kl", float(kl.detach()))
        return _AddLoss.apply(values, kl, self.weight), log_prob, entropy


def kl_divergence(target, distribution) -> torch.Tensor:
    """KL(target || distribution) per observation, summed over the action's independent parts: the
    dimensions of a Gaussian (gait or joint commands), or the choices of each part of a MultiDiscrete
    action (``agent.action_mode: discrete``: a Categorical per part, whose KLs add as the parts do)."""
    if isinstance(target.distribution, list):
        parts = zip(target.distribution, distribution.distribution)
        return torch.stack([torch.distributions.kl_divergence(t, d) for t, d in parts], dim=1).sum(dim=1)
    return sum_independent_dims(torch.distributions.kl_divergence(target.distribution, distribution.distribution))


def anchor_from_config(config: Config, student: dict | None) -> StudentAnchor | None:
    """The callback a run of ``config`` trains with, or None when it asks for neither piece."""
    train = config.train
    if train.value_warmup_steps == 0 and train.bc_coef == 0:
        return None
    return StudentAnchor(
        student if train.bc_coef > 0 else None,
        train.value_warmup_steps,
        train.value_warmup_epochs,
        train.bc_coef,
        train.bc_decay_steps,
    )
