"""The recurrent student of ``aaai train --teacher reference`` (``train.student_policy: lstm``).

DAgger as in :mod:`aaai.train.student`, with a student that remembers: sb3-contrib's
``RecurrentPPO`` policy (``MultiInputLstmPolicy``). The observation's features go through an LSTM
of ``train.net_width`` units, then through two layers of that width to the mean action, as the
stateless student's do; the critic has an LSTM of its own, untrained by DAgger and there for a
RecurrentPPO fine-tune (``aaai train --init-from RUN``, which picks RecurrentPPO for such a model).

Playing (:class:`RecurrentActor`): the student's hidden state is carried from one decision to the
next through the episode and starts from zero at its start. The student sees every observation of
its episodes, also those where the teacher drives, so its state is the one its own history gives.

Fitting: the episodes are kept whole (the data records where each one starts). A refit regresses
the student's mean action on the teacher's labels (mean squared error, Adam; with
``agent.action_mode: discrete`` it classifies the teacher's choices, cross-entropy) by truncated
backpropagation through time, in chunks of ``train.dagger_sequence`` decisions: the gradient stops
at a chunk's start, the memory does not. At an episode's start the state is zero, as sb3-contrib's
recurrent rollout buffer masks it at ``episode_starts``; the padding after a shorter sequence's end
is masked out. Two ways of stepping (``train.dagger_chunks``):

- ``shuffled`` (:func:`fit_shuffled_chunks`, the default): each pass first plays the memory over
  every episode and keeps the hidden state at each chunk's start (no gradient); each step of Adam
  is then on chunks drawn from all the data, each started from its kept state.
- ``episodes`` (:func:`fit_sequences`, as runs before the option): a batch is several episodes side
  by side, each from its start (episodes of similar length together, sorted within a shuffled
  pool), one step per chunk, the hidden state carried, detached, from chunk to chunk. Its steps
  follow the same few episodes for many steps in a row, and the LSTM fitted the labels hardly better
  than their mean (experiments/students/README.md).

Either may let the step size fall along a cosine (``train.dagger_learning_rate_end``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aaai.config import Config, ConfigError

BATCH_DECISIONS = 1024  # decisions per batch: lanes = BATCH_DECISIONS // train.dagger_sequence episodes side by side
POOL = 8  # batches' worth of episodes shuffled together, then sorted by length
MAX_GRAD_NORM = 1.0  # an LSTM's gradients clipped, as RecurrentPPO clips its own (max_grad_norm)
POLICY = "MultiInputLstmPolicy"


def policy_kwargs(net_width: int, log_std_init: float) -> dict:
    """The recurrent student's network: an LSTM of ``net_width`` units, then two layers of that width."""
    return {"lstm_hidden_size": net_width, "net_arch": [net_width, net_width], "log_std_init": log_std_init}


def build_policy(observation_space, action_space, net_width: int, log_std_init: float = 0.0, learning_rate=1e-3):
    """The student: sb3-contrib's MultiInputLstmPolicy as RecurrentPPO builds it."""
    from sb3_contrib.common.recurrent.policies import RecurrentMultiInputActorCriticPolicy

    return RecurrentMultiInputActorCriticPolicy(
        observation_space, action_space, lambda _: learning_rate, **policy_kwargs(net_width, log_std_init)
    )


def new_model(env, config: Config) -> Any:
    """A RecurrentPPO model holding the student (what the run saves, and a fine-tune goes on training)."""
    from sb3_contrib import RecurrentPPO

    train = config.train
    return RecurrentPPO(
        POLICY,
        env,
        policy_kwargs=policy_kwargs(train.net_width, train.log_std_init),
        learning_rate=train.learning_rate,
        n_steps=train.n_steps,
        batch_size=train.batch_size,
        seed=train.seed,
        device="cpu",
        verbose=0,
    )


def check_available() -> None:
    """sb3-contrib is there (the train extra), or one line says so."""
    try:
        import sb3_contrib  # noqa: F401
    except ImportError:
        raise ConfigError(
            "config key 'train.student_policy': got 'lstm', which needs sb3-contrib (the train extra: "
            "pip install sb3-contrib); allowed without it: mlp"
        ) from None


def is_recurrent(path: str | Path) -> bool:
    """Whether a model file holds a recurrent policy (its policy class read as text, nothing unpickled).
    A file whose class cannot be read counts as not recurrent: the ordinary checks that follow refuse
    it, naming what is wrong (another environment's config first)."""
    from aaai.config import ConfigError
    from aaai.scoring.model_archive import read_archive
    from aaai.scoring.model_io import policy_class_name

    try:
        return policy_class_name(read_archive(Path(path))).startswith("Recurrent")
    except ConfigError:
        return False


class RecurrentActor:
    """The student acting in its episodes: its deterministic action, the hidden state carried from
    one decision to the next; :meth:`reset` at an episode's start."""

    def __init__(self, policy):
        self.policy = policy
        self.reset()

    def reset(self) -> None:
        self.state: Any = None
        self.start = True

    def __call__(self, observation: dict) -> np.ndarray:
        action, self.state = self.policy.predict(
            observation, state=self.state, episode_start=np.array([self.start]), deterministic=True
        )
        self.start = False
        return action


# --- fitting on sequences ---------------------------------------------------------------
def episode_spans(starts: np.ndarray) -> list[tuple[int, int]]:
    """(first, end) of each episode in data whose ``starts`` flags mark each episode's first decision."""
    begins = np.flatnonzero(np.asarray(starts, bool))
    if len(starts) and (not len(begins) or begins[0] != 0):
        raise ConfigError("the student's data does not start with an episode's start; allowed: whole episodes")
    ends = np.append(begins[1:], len(starts))
    return [(int(b), int(e)) for b, e in zip(begins, ends)]


def plan_batches(spans: list[tuple[int, int]], lanes: int, generator) -> list[list[int]]:
    """The episodes of one pass, ``lanes`` to a batch: shuffled, sorted by length within pools of
    :data:`POOL` batches, and the batches shuffled."""
    import torch

    order = torch.randperm(len(spans), generator=generator).tolist()
    batches: list[list[int]] = []
    for first in range(0, len(order), lanes * POOL):
        pool = sorted(order[first : first + lanes * POOL], key=lambda e: spans[e][1] - spans[e][0])
        batches.extend(pool[i : i + lanes] for i in range(0, len(pool), lanes))
    return [batches[i] for i in torch.randperm(len(batches), generator=generator).tolist()]


def cosine_schedule(start: float, end: float | None, steps: int):
    """The step size of step ``i`` of ``steps``: ``start`` falling to ``end`` along half a cosine
    (the last step at ``end``); ``start`` throughout when ``end`` is None."""
    import math

    if end is None or steps < 2:
        return lambda i: start
    return lambda i: end + (start - end) * 0.5 * (1.0 + math.cos(math.pi * min(i, steps - 1) / (steps - 1)))


def chunk_means(policy, observations: dict, state: tuple, lanes: int) -> tuple[Any, tuple]:
    """The mean actions of ``lanes`` sequences side by side (observations lane by lane, each lane's
    decisions in order), from the hidden ``state``; the state they end with."""
    import torch

    features = policy.extract_features(observations, policy.pi_features_extractor)
    no_starts = torch.zeros(features.shape[0])  # a lane's episode start is its zero state
    latent, state = policy._process_sequence(features, state, no_starts, policy.lstm_actor)
    return policy.action_net(policy.mlp_extractor.forward_actor(latent)), state


def lane_rows(begins, lengths, steps) -> tuple[Any, Any]:
    """Lanes side by side: lane i takes decisions ``begins[i] + steps`` of its sequence of ``lengths[i]``
    (padded by repeating its last one). The row ``index`` of each into the data, lane by lane, and a
    ``mask``, 1 where the decision is a real one."""
    import torch

    mask = (steps[None, :] < lengths[:, None]).reshape(-1).float()
    index = (begins[:, None] + torch.minimum(steps[None, :], lengths[:, None] - 1)).reshape(-1)
    return mask, index


def decision_losses(action_space, outputs, targets):
    """Each decision's distance from the teacher's label: the mean squared error of a continuous
    action's parts; for discrete actions (``agent.action_mode: discrete``, ``outputs`` the logits of
    every part's choices), the sum over the action's parts of the cross-entropy of that part's choice,
    as the stateless student of choices is fitted (aaai.train.student.imitation_loss)."""
    import torch
    from gymnasium import spaces

    if isinstance(action_space, spaces.MultiDiscrete):
        parts = torch.split(outputs, [int(n) for n in action_space.nvec], dim=1)
        choices = targets.long().unbind(1)
        cross_entropy = torch.nn.functional.cross_entropy
        return sum(cross_entropy(logits, choice, reduction="none") for logits, choice in zip(parts, choices))
    return ((outputs - targets) ** 2).mean(dim=-1)


def masked_step(policy, optimizer, means, targets, mask, step_size: float):
    """One step of Adam on the loss of ``means`` (:func:`decision_losses`: mean squared error, or the
    choices' cross-entropy) over the real decisions (``mask``), gradients clipped as RecurrentPPO
    clips its own; returns the loss."""
    import torch

    errors = decision_losses(policy.action_space, means, targets)
    loss = (errors * mask).sum() / mask.sum()
    optimizer.zero_grad()
    loss.backward()
    torch.nn.utils.clip_grad_norm_(policy.parameters(), MAX_GRAD_NORM)
    for group in optimizer.param_groups:
        group["lr"] = step_size
    optimizer.step()
    return loss


def fit_sequences(
    policy,
    observations: dict,
    labels: np.ndarray,
    starts: np.ndarray,
    epochs: int,
    seed: int,
    sequence: int,
    learning_rate: float = 1e-3,
    batch_decisions: int = BATCH_DECISIONS,
    final_learning_rate: float | None = None,
) -> float:
    """Regresses the recurrent policy's mean action on the labels by truncated backpropagation
    through time (chunks of ``sequence`` decisions, the hidden state carried between them);
    returns the last pass's mean loss per decision. With ``final_learning_rate`` the step size
    falls from ``learning_rate`` to it along a cosine over the fit's steps; without, it stays."""
    import torch

    generator = torch.Generator().manual_seed(seed)
    inputs = {key: torch.as_tensor(value, dtype=torch.float32) for key, value in observations.items()}
    targets = torch.as_tensor(labels, dtype=torch.float32)
    spans = episode_spans(starts)
    lanes = max(1, batch_decisions // sequence)
    layers, _, hidden = policy.lstm_hidden_state_shape
    plans = [plan_batches(spans, lanes, generator) for _ in range(epochs)]
    steps_total = sum(-(-max(spans[e][1] - spans[e][0] for e in batch) // sequence) for plan in plans for batch in plan)
    optimizer = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    step_size = cosine_schedule(learning_rate, final_learning_rate, steps_total)
    policy.set_training_mode(True)
    loss_sum, decisions, step = 0.0, 0.0, 0
    for plan in plans:
        loss_sum, decisions = 0.0, 0.0
        for batch in plan:
            begins = torch.tensor([spans[e][0] for e in batch])
            lengths = torch.tensor([spans[e][1] - spans[e][0] for e in batch])
            zeros = torch.zeros(layers, len(batch), hidden)
            state: tuple = (zeros, zeros.clone())
            for first in range(0, int(lengths.max()), sequence):
                steps = torch.arange(first, min(first + sequence, int(lengths.max())))
                mask, index = lane_rows(begins, lengths, steps)
                means, state = chunk_means(policy, {k: v[index] for k, v in inputs.items()}, state, len(batch))
                loss = masked_step(policy, optimizer, means, targets[index], mask, step_size(step))
                step += 1
                state = (state[0].detach(), state[1].detach())  # carried on; the gradient stops here
                loss_sum, decisions = loss_sum + loss.item() * mask.sum().item(), decisions + mask.sum().item()
    policy.set_training_mode(False)
    return loss_sum / max(decisions, 1.0)


def chunk_spans(spans: list[tuple[int, int]], sequence: int) -> list[tuple[int, int]]:
    """(first, end) of each chunk of ``sequence`` decisions of each episode, episode by episode, in order."""
    return [(first, min(first + sequence, end)) for begin, end in spans for first in range(begin, end, sequence)]


def start_states(policy, inputs: dict, spans: list[tuple[int, int]], sequence: int, lanes: int = 256) -> tuple:
    """The hidden state (h, c) at the start of each chunk of :func:`chunk_spans`, as the policy's
    memory carries it from its episode's start (zero there); no gradient. Shapes (layers, chunks, hidden)."""
    import torch

    layers, _, hidden = policy.lstm_hidden_state_shape
    per_episode = [-(-(end - begin) // sequence) for begin, end in spans]
    offsets = np.concatenate([[0], np.cumsum(per_episode)]).astype(int)
    h = torch.zeros(layers, int(offsets[-1]), hidden)
    c = torch.zeros_like(h)
    with torch.no_grad():
        for first_episode in range(0, len(spans), lanes):
            batch = list(range(first_episode, min(first_episode + lanes, len(spans))))
            begins = torch.tensor([spans[e][0] for e in batch])
            lengths = torch.tensor([spans[e][1] - spans[e][0] for e in batch])
            zeros = torch.zeros(layers, len(batch), hidden)
            state: tuple = (zeros, zeros.clone())
            for chunk, first in enumerate(range(0, int(lengths.max()), sequence)):
                live = [i for i, e in enumerate(batch) if chunk < per_episode[e]]  # the episodes with a k-th chunk
                rows = torch.tensor([int(offsets[batch[i]]) + chunk for i in live])
                h[:, rows], c[:, rows] = state[0][:, live], state[1][:, live]
                steps = torch.arange(first, min(first + sequence, int(lengths.max())))
                _, index = lane_rows(begins, lengths, steps)
                _, state = chunk_means(policy, {key: v[index] for key, v in inputs.items()}, state, len(batch))
    return h, c


def fit_shuffled_chunks(
    policy,
    observations: dict,
    labels: np.ndarray,
    starts: np.ndarray,
    epochs: int,
    seed: int,
    sequence: int,
    learning_rate: float = 1e-3,
    batch_decisions: int = BATCH_DECISIONS,
    final_learning_rate: float | None = None,
) -> float:
    """As :func:`fit_sequences`, but each step of Adam is on chunks drawn from the whole data (any
    episode, any place in it), each started from the hidden state its episode's history gives it,
    computed by the policy at the start of each pass (no gradient); returns the last pass's mean loss."""
    import torch

    generator = torch.Generator().manual_seed(seed)
    inputs = {key: torch.as_tensor(value, dtype=torch.float32) for key, value in observations.items()}
    targets = torch.as_tensor(labels, dtype=torch.float32)
    spans = episode_spans(starts)
    chunks = chunk_spans(spans, sequence)
    lanes = max(1, batch_decisions // sequence)
    per_pass = -(-len(chunks) // lanes)
    optimizer = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    step_size = cosine_schedule(learning_rate, final_learning_rate, epochs * per_pass)
    begins_all = torch.tensor([b for b, _ in chunks])
    lengths_all = torch.tensor([e - b for b, e in chunks])
    loss_sum, decisions, step = 0.0, 0.0, 0
    for _ in range(epochs):
        policy.set_training_mode(False)
        h, c = start_states(policy, inputs, spans, sequence)
        policy.set_training_mode(True)
        order = torch.randperm(len(chunks), generator=generator)
        loss_sum, decisions = 0.0, 0.0
        for first in range(0, len(chunks), lanes):
            ids = order[first : first + lanes]
            begins, lengths = begins_all[ids], lengths_all[ids]
            mask, index = lane_rows(begins, lengths, torch.arange(int(lengths.max())))
            means, _ = chunk_means(policy, {k: v[index] for k, v in inputs.items()}, (h[:, ids], c[:, ids]), len(ids))
            loss = masked_step(policy, optimizer, means, targets[index], mask, step_size(step))
            step += 1
            loss_sum, decisions = loss_sum + loss.item() * mask.sum().item(), decisions + mask.sum().item()
    policy.set_training_mode(False)
    return loss_sum / max(decisions, 1.0)
