"""Does TorchRL's asynchronous collector overlap collection with PPO's update here? Its training
rate against the environment alone, its policy lag, and what it learns on `make demo`'s task.

The shipped training config (8 environments of L0 d0-2, rays and the body senses, two hidden
layers of 128, 8 x 256 steps a batch, 10 epochs of minibatches of 256), stepped three or four ways, alternated round
by round (the order rotated; aaai.tools.rounds):

- ``env alone``: the training vector env in this process, random actions, nothing else (as
  ``aaai bench``'s training row, ``aaai.tools.bench._VecLoop``);
- ``TorchRL async PPO``: TorchRL's ``MultiAsyncCollector`` with one worker process stepping the 8
  environments (``GymWrapper`` over a Gymnasium ``SyncVectorEnv``; each environment draws its episodes from a
  curriculum of its own, uniform over the cells as the shipped sampler) while this process
  updates on the batch before: TorchRL's ``GAE`` and ``ClipPPOLoss`` (clip 0.2, advantages
  normalised per minibatch, value loss 0.5 x MSE, gradients clipped at 0.5, Adam 3e-4), the
  weights sent to the worker after each batch's update (``update_policy_weights_``). A round's
  time includes waiting for the batch the worker was collecting when the round's last update
  ended, so the worker's work of a round is inside the round.
- ``TorchRL env, random actions``: the same TorchRL env in this process, ``env.rollout`` with
  random actions (TorchRL's cost of stepping, without a policy or a worker process);
- with ``--sb3``, ``stable-baselines3 PPO (sequential)``: ``aaai train``'s PPO (``_PPOLoop``).

Policy lag: the policy carries a buffer with the number of updates the learner had sent when the
weights were synced; every collected step records it (``policy_version``), and the lag of a step
is the learner's count when it learns from the step less that number.

Then ``--train-seeds``: a run of ``--train-steps`` steps per seed (the demo's budget), timed, and
scored on the demo's 30 reserved episodes (L0 d0-2, 10 seeds each) with aaai's evaluation
(``aaai.scoring.evaluation.evaluate``), TorchRL's deterministic action
(``ExplorationType.DETERMINISTIC``).

Resumable: every round of rates is appended to bench/torchrl_probe.csv as measured (``kind``
rate); each trained seed to the same file (``kind`` train); seeds already there are skipped.
bench/torchrl_probe.md is written from the CSV.

    PYTHONPATH=bench .venv/bin/python bench/torchrl_probe.py --rounds 3 --steps 8192 --train-seeds 0,1
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np

OUT = Path(__file__).resolve().parent
CSV = OUT / "torchrl_probe.csv"
SB3 = "stable-baselines3 PPO (sequential)"
_SCRATCH: list[tempfile.TemporaryDirectory] = []


def scratch(name: str) -> Path:
    """A folder for an SB3 run's files, under one temporary folder removed when the probe exits."""
    if not _SCRATCH:
        _SCRATCH.append(tempfile.TemporaryDirectory(prefix="aaai-torchrl-probe-"))
    return Path(_SCRATCH[0].name) / name


FIELDS = ["when", "kind", "round", "runner", "steps_per_s", "seconds", "seed", "passed", "episodes", "load", "note"]


# --- the environments in the collector's worker process -------------------------------------
class OwnCurriculum(gym.Wrapper):
    """An AnimalAIEnv with the run's training shaping whose episodes a curriculum of its own draws
    (the shipped sampler is uniform, so a curriculum per environment draws as the shared one)."""

    def __init__(self, config, index: int):
        from aaai.config import env_part, load_config
        from aaai.env import AnimalAIEnv
        from aaai.train.curriculum import Curriculum

        super().__init__(AnimalAIEnv(config=env_part(config, config.train.reward_shaping)))
        self.curriculum = Curriculum.from_config(load_config(config, seed=config.train.seed * 1000 + index))
        self.cell = (0, 0)
        self.task_return = 0.0

    def reset(self, *, seed=None, options=None):
        level, difficulty, episode_seed = self.curriculum.sample()
        self.cell, self.task_return = (level, difficulty), 0.0
        observation, _ = self.env.reset(seed=episode_seed, options={"level": level, "difficulty": difficulty})
        return observation, {}  # the same (empty) info at every step: TorchRL reads its keys as specs

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self.task_return += float(reward) - float(info["reward_terms"]["shaping"])
        if terminated or truncated:
            self.curriculum.record(*self.cell, self.task_return, info["max_reward"])
        return observation, reward, terminated, truncated, {}


def make_one(config, index: int) -> gym.Env:
    return gym.wrappers.FlattenObservation(OwnCurriculum(config, index))


def make_envs(config):
    """The ``num_envs`` environments as one TorchRL env: ``GymWrapper`` over Gymnasium's
    ``SyncVectorEnv`` (same-step autoreset, which TorchRL's wrapper reads), as TorchRL wraps a
    vector env. (A ``SerialEnv`` of one ``GymWrapper`` each stepped at 0.3 of the environment
    alone, this at 0.5, both with random actions in one process.)"""
    import torch
    from gymnasium.vector import AutoresetMode, SyncVectorEnv
    from torchrl.envs import GymWrapper

    torch.set_num_threads(1)
    makers = [partial(make_one, config, i) for i in range(config.train.num_envs)]
    return GymWrapper(SyncVectorEnv(makers, autoreset_mode=AutoresetMode.SAME_STEP), device="cpu")


class TorchRLEnvLoop:
    """The same TorchRL env in this process, random actions (``env.rollout``): TorchRL's own cost
    of stepping, without a policy or a worker process."""

    def __init__(self, config, steps: int):
        self.env, self.steps = make_envs(config), steps
        self.n = config.train.num_envs

    def __call__(self, steps: int | None = None) -> float:
        n = max(1, (steps or self.steps) // self.n)
        started = time.perf_counter()
        self.env.rollout(n, break_when_any_done=False)
        return n * self.n / (time.perf_counter() - started)

    def close(self) -> None:
        self.env.close(raise_if_closed=False)


# --- the policy, the value and TorchRL's loss ------------------------------------------------
def build(config, observation_size: int, action_size: int):
    """TorchRL's actor (TanhNormal, a state-independent scale), critic, GAE and ClipPPOLoss, and the
    policy the collector runs: the actor followed by a module writing its weights' version."""
    import torch
    from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule, TensorDictSequential
    from torch import nn
    from torchrl.modules import MLP, ProbabilisticActor, TanhNormal, ValueOperator
    from torchrl.objectives import ClipPPOLoss
    from torchrl.objectives.value import GAE

    train = config.train
    width = train.net_width
    torch.manual_seed(train.seed)
    body = nn.Sequential(
        MLP(in_features=observation_size, out_features=action_size, num_cells=[width, width], activation_class=nn.Tanh),
        AddStateIndependentNormalScale(action_size, scale_mapping="exp", init_value=train.log_std_init),
    )
    actor = ProbabilisticActor(
        TensorDictModule(body, in_keys=["observation"], out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"],
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True,
    )
    critic = ValueOperator(
        MLP(in_features=observation_size, out_features=1, num_cells=[width, width], activation_class=nn.Tanh),
        in_keys=["observation"],
    )
    version = TensorDictModule(Version(), in_keys=["observation"], out_keys=["policy_version"])
    policy = TensorDictSequential(actor, version)
    advantage = GAE(gamma=train.gamma, lmbda=train.gae_lambda, value_network=critic, average_gae=False)
    loss = ClipPPOLoss(
        actor,
        critic,
        clip_epsilon=0.2,
        entropy_bonus=train.ent_coef > 0,
        entropy_coeff=train.ent_coef,
        critic_coeff=0.5,
        loss_critic_type="l2",
        normalize_advantage=True,
    )
    optimizer = torch.optim.Adam(loss.parameters(), lr=train.learning_rate, eps=1e-5)
    return policy, actor, version, advantage, loss, optimizer


class Version(__import__("torch").nn.Module):
    """The number of updates the learner had made when these weights were sent (a buffer, so it
    travels with the weights)."""

    def __init__(self):
        import torch

        super().__init__()
        self.register_buffer("version", torch.zeros(1))

    def forward(self, observation):
        return self.version.expand(*observation.shape[:-1], 1).clone()


def update(data, advantage, loss, optimizer, train) -> None:
    """PPO's update on one batch, as TorchRL's PPO tutorial wires it: GAE once, then ``n_epochs``
    passes of shuffled minibatches through ClipPPOLoss, Adam, gradients clipped at 0.5."""
    import torch

    with torch.no_grad():
        advantage(data)
    flat = data.reshape(-1)
    for _ in range(train.n_epochs):
        order = torch.randperm(flat.shape[0])
        for start in range(0, flat.shape[0], train.batch_size):
            losses = loss(flat[order[start : start + train.batch_size]])
            total = losses["loss_objective"] + losses["loss_critic"] + losses.get("loss_entropy", 0.0)
            optimizer.zero_grad()
            total.backward()
            torch.nn.utils.clip_grad_norm_(loss.parameters(), 0.5)
            optimizer.step()


def update_costs(config, rounds: int) -> dict[str, list[float]]:
    """The update alone, in this process with nothing else running: TorchRL's (:func:`update`) on a
    batch of 8 x 256 steps the policy collected, against stable-baselines3's ``PPO.train`` on a
    rollout of the same size (``aaai train``'s PPO), alternated; microseconds per environment step."""
    import torch

    from aaai.tools.bench import _PPOLoop

    env = make_envs(config)
    observations, actions = env.observation_spec["observation"].shape[-1], env.action_spec.shape[-1]
    policy, _, _, advantage, loss, optimizer = build(config, observations, actions)
    train = config.train
    with torch.no_grad():
        data = env.rollout(train.n_steps, policy, break_when_any_done=False)
    env.close(raise_if_closed=False)
    steps = data.numel()
    sb3 = _PPOLoop(config, steps, scratch("sb3-updates"))
    sb3(steps)  # one rollout collected and learned: its buffer is what PPO.train learns from again

    def timed(learn) -> float:
        started = time.perf_counter()
        learn()
        return 1e6 * (time.perf_counter() - started) / steps

    runners = {
        "TorchRL ClipPPOLoss update, us a step": lambda: timed(lambda: update(data, advantage, loss, optimizer, train)),
        "stable-baselines3 PPO.train, us a step": lambda: timed(sb3.model.train),
    }
    try:
        for runner in runners.values():
            runner()  # warm-up
        from aaai.tools.rounds import alternate

        return alternate(runners, rounds)
    finally:
        sb3.close()


class AsyncPPO:
    """TorchRL's MultiAsyncCollector (1 worker process, the 8 environments) and PPO's update here;
    each call learns ``steps`` more steps (whole batches) and returns steps/s."""

    def __init__(self, config, steps: int, lags: list | None = None):
        import torch
        from torchrl.collectors import MultiAsyncCollector

        torch.set_num_threads(1)
        self.config, self.steps, self.lags = config, steps, lags
        probe = make_envs(config)
        obs_size = probe.observation_spec["observation"].shape[-1]
        act_size = probe.action_spec.shape[-1]
        probe.close(raise_if_closed=False)
        self.policy, self.actor, self.version, self.advantage, self.loss, self.optimizer = build(
            config, obs_size, act_size
        )
        train = config.train
        self.batch = train.n_steps * train.num_envs
        self.collector = MultiAsyncCollector(
            [partial(make_envs, config)],
            self.policy,
            frames_per_batch=self.batch,
            total_frames=-1,
            device="cpu",
            num_threads=1,
        )
        self.collector.set_seed(train.seed)
        self.batches = iter(self.collector)
        self.updates = 0
        self.learned = 0
        self.waiting = self.updating = 0.0  # seconds waiting for a batch, and updating on them

    def learn_batch(self) -> int:
        started = time.perf_counter()
        data = next(self.batches)
        waited = time.perf_counter()
        train = self.config.train
        if self.lags is not None:
            self.lags.extend((self.updates - data["policy_version"].reshape(-1)).tolist())
        update(data, self.advantage, self.loss, self.optimizer, train)
        self.updates += 1
        self.version.module.version.fill_(self.updates)
        self.collector.update_policy_weights_()
        self.learned += data.numel()
        self.waiting += waited - started
        self.updating += time.perf_counter() - waited
        return data.numel()

    def __call__(self, steps: int | None = None) -> float:
        goal, done = steps or self.steps, 0
        started = time.perf_counter()
        while done < goal:
            done += self.learn_batch()
        while self.collector.queue_out.empty():  # the worker's batch of this round, finished
            time.sleep(0.001)
        return done / (time.perf_counter() - started)

    def close(self) -> None:
        self.collector.shutdown()


# --- the policy as aaai's evaluation plays it ------------------------------------------------
def acting(actor, env):
    """policy(observation) -> action: the flattened observation through the actor, its deterministic action."""
    import torch
    from tensordict import TensorDict
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    space = env.observation_space

    def act(observation):
        flat = torch.as_tensor(gym.spaces.flatten(space, observation), dtype=torch.float32)
        with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
            out = actor(TensorDict({"observation": flat}, batch_size=[]))
        return out["action"].numpy().astype(np.float64)

    return act


def score(config, actor) -> tuple[int, int]:
    from aaai.scoring.evaluation import evaluate
    from aaai.scoring.plan import cells_for
    from aaai.scoring.policies import external
    from aaai.train.curriculum import episode_passed

    cur = config.curriculum
    cells = cells_for(list(cur.levels), list(cur.difficulties), "reserved", config.eval.seeds_per_cell)
    with tempfile.TemporaryDirectory(prefix="aaai-torchrl-probe-") as folder:
        rows = evaluate(
            external("torchrl-probe"),
            cells,
            Path(folder) / "scores.csv",
            config,
            make_policy=lambda env: acting(actor, env),
        )
    passed = sum(episode_passed(float(r["return"]), float(r["max_reward"])) for r in rows)
    return passed, len(rows)


def train_seed(config, seed: int, total: int) -> dict:
    from aaai.config import load_config
    from aaai.tools.rounds import load

    config = load_config(config, seed=seed)
    before = load()
    started = time.perf_counter()
    learner = AsyncPPO(config, total)
    try:
        while learner.learned < total:
            learner.learn_batch()
    finally:
        learner.close()
    seconds = time.perf_counter() - started
    passed, episodes = score(config, learner.actor)
    return {"seconds": round(seconds, 1), "passed": passed, "episodes": episodes, "load": f"{before}->{load()}"}


# --- the CSV and the report ------------------------------------------------------------------
def read_rows() -> list[dict]:
    if not CSV.exists():
        return []
    with CSV.open(newline="") as handle:
        return list(csv.DictReader(handle))


def append(row: dict) -> None:
    new = not CSV.exists()
    with CSV.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, FIELDS)
        if new:
            writer.writeheader()
        writer.writerow({"when": time.strftime("%Y-%m-%dT%H:%M:%S"), **row})


def fig(values: list[float], digits: int = 0) -> str:
    return f"{statistics.median(values):,.{digits}f} ({min(values):,.{digits}f}..{max(values):,.{digits}f})"


def report() -> None:
    import torchrl

    rows = read_rows()
    lines = [f"# TorchRL {torchrl.__version__} async PPO against the environment alone", ""]
    runs = sorted({r["note"] for r in rows if r["kind"] == "rate"})
    if runs:
        lines += [
            "Each run: alternated rounds (`bench/torchrl_probe.py`); steps/s median (min..max); ratio per round.",
            "",
            "| run | rounds x steps | load before -> after | env alone steps/s | TorchRL async PPO steps/s | "
            "TorchRL env, random actions, steps/s | stable-baselines3 PPO / env alone | async / env alone | "
            "TorchRL env / env alone | "
            "policy lag, updates (median, min..max) | learner us a step: waiting for a batch, updating |",
            "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
    for run in runs:
        own = [r for r in rows if r["kind"] == "rate" and r["note"] == run]
        env = [float(r["steps_per_s"]) for r in own if r["runner"] == "env alone"]
        ppo = [float(r["steps_per_s"]) for r in own if r["runner"] == "TorchRL async PPO"]
        alone = [float(r["steps_per_s"]) for r in own if r["runner"] == "TorchRL env, random actions"]
        lag = [r["steps_per_s"] for r in own if r["runner"] == "policy lag"]
        split = [r["steps_per_s"] for r in own if r["runner"].startswith("learner us")]
        ratios = [a / b for a, b in zip(ppo, env)]
        wrapped = [a / b for a, b in zip(alone, env)]
        sb3 = [float(r["steps_per_s"]) for r in own if r["runner"] == SB3]
        sb3_text = fig([a / b for a, b in zip(sb3, env)], 2) if sb3 else "-"
        lines.append(
            f"| {run} | {own[0]['seconds']} | {own[0]['load']} | {fig(env)} | {fig(ppo)} | {fig(alone)} | {sb3_text} | "
            f"{fig(ratios, 2)} | {fig(wrapped, 2)} | {lag[0] if lag else '-'} | {split[0] if split else '-'} |"
        )
    costs = [r for r in rows if r["kind"] == "update"]
    if costs:
        names = list(dict.fromkeys(r["runner"] for r in costs))
        mine, theirs = ([float(r["steps_per_s"]) for r in costs if r["runner"] == name] for name in names)
        lines += [
            "",
            f"The update alone, in this process (`--updates`, {len(mine)} alternated rounds, load {costs[0]['load']}), "
            "us per environment step:",
            "",
            *(f"- {name}: {fig([float(r['steps_per_s']) for r in costs if r['runner'] == name])}" for name in names),
            f"- TorchRL's / stable-baselines3's: {fig([a / b for a, b in zip(mine, theirs)], 2)}",
        ]
    trained = [r for r in rows if r["kind"] == "train"]
    if trained:
        lines += [
            "",
            "Trained as `make demo` (L0 d0-2, the shipped config), scored on its 30 reserved episodes:",
            "",
            "| seed | steps | training s | load before -> after | passed or better |",
            "|---:|---:|---:|---|---:|",
        ]
        for r in trained:
            passed = f"{int(r['passed']) / int(r['episodes']):.0%} ({r['passed']}/{r['episodes']})"
            lines.append(f"| {r['seed']} | {r['note']} | {r['seconds']} | {r['load']} | {passed} |")
    (OUT / "torchrl_probe.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=16384, help="steps per runner and round")
    parser.add_argument("--train-seeds", default="", help="seeds to train and score, e.g. 0,1")
    parser.add_argument("--train-steps", type=int, default=100_000)
    parser.add_argument("--updates", type=int, default=0, help="rounds of the update alone against SB3's")
    parser.add_argument("--sb3", action="store_true", help="stable-baselines3's PPO (aaai train's) in the rounds too")
    args = parser.parse_args()

    import torch

    from aaai.tools.bench import _VecLoop, training_config
    from aaai.tools.rounds import alternate, load

    torch.set_num_threads(1)
    config = training_config()
    if args.rounds:
        run = time.strftime("%Y-%m-%dT%H:%M")
        lags: list = []
        before = load()
        runners: dict = {
            "env alone": _VecLoop(config, False, args.steps),
            "TorchRL env, random actions": TorchRLEnvLoop(config, args.steps),
            "TorchRL async PPO": AsyncPPO(config, args.steps),
        }
        if args.sb3:
            from aaai.tools.bench import _PPOLoop

            runners[SB3] = _PPOLoop(config, args.steps, scratch("sb3-rates"))
        try:
            for runner in runners.values():
                runner(4096)  # warm-up: the worker process started, two batches learned
            learner = runners["TorchRL async PPO"]
            learner.lags = lags
            learner.waiting = learner.updating = learner.learned = 0
            rates = alternate(runners, args.rounds)
            split = (1e6 * learner.waiting / learner.learned, 1e6 * learner.updating / learner.learned)
        finally:
            for runner in runners.values():
                runner.close()
        machine = f"{before}->{load()}"
        for name, values in rates.items():
            for i, value in enumerate(values):
                append(
                    {
                        "kind": "rate",
                        "round": i,
                        "runner": name,
                        "steps_per_s": round(value, 1),
                        "seconds": f"{args.rounds} x {args.steps}",
                        "load": machine,
                        "note": run,
                    }
                )
        append(
            {
                "kind": "rate",
                "round": "",
                "runner": "policy lag",
                "steps_per_s": fig(lags, 1) if lags else "-",
                "seconds": f"{args.rounds} x {args.steps}",
                "load": machine,
                "note": run,
            }
        )
        append(
            {
                "kind": "rate",
                "round": "",
                "runner": "learner us a step: waiting, updating",
                "steps_per_s": f"{split[0]:.0f}, {split[1]:.0f}",
                "seconds": f"{args.rounds} x {args.steps}",
                "load": machine,
                "note": run,
            }
        )
    if args.updates:
        before = load()
        costs = update_costs(config, args.updates)
        machine = f"{before}->{load()}"
        for name, values in costs.items():
            for i, value in enumerate(values):
                append({"kind": "update", "round": i, "runner": name, "steps_per_s": round(value, 1), "load": machine})
    done = {r["seed"] for r in read_rows() if r["kind"] == "train"}
    for seed in [int(s) for s in args.train_seeds.split(",") if s]:
        if str(seed) in done:
            continue
        result = train_seed(config, seed, args.train_steps)
        append({"kind": "train", "seed": seed, "note": args.train_steps, **result})
        print(seed, result, flush=True)
    report()


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
