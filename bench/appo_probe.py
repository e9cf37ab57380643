"""Does RLlib's APPO overlap collection with the update here? Its training rate against the
environment alone, and its policy lag.

The shipped training config (8 environments of L0 d0-2, rays and the body senses, two hidden layers
of 128), stepped three ways, alternated round by round (the order rotated):

- ``env alone``: the training vector env in this process, random actions, nothing else (as
  ``aaai bench``'s training row);
- ``APPO``: RLlib's APPO (new API stack; 1 EnvRunner process stepping the 8 environments, the
  learner in this process; V-trace, clip 0.2; each round ``algo.train()`` until ``--steps`` more
  environment steps are sampled); the environments and the curriculum actor are the rllib
  backend's (aaai.train.rllib_learner);
- ``PPO (rllib)``: the rllib backend's PPO on the same environments and EnvRunner, for reference.

The policy lag is the learner's weights version less the version the EnvRunner sampled with
(RLlib's ``weights_seq_no``), in learner updates, at the end of each APPO iteration. Writes
bench/appo_probe.json and bench/appo_probe.md; each round is appended to bench/appo_probe.csv
as it ends.

    .venv/bin/python bench/appo_probe.py --rounds 3 --steps 4096
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent


def appo_config(config, sampler: str, env_runners: int, epochs: int):
    from ray.rllib.algorithms.appo import APPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    from aaai.train.rllib_learner import ENV_NAME, flatten_observations

    train = config.train
    width = train.net_width
    return (
        APPOConfig()
        .environment(ENV_NAME, env_config={"aaai_config": config, "sampler": sampler})
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=max(1, math.ceil(train.num_envs / env_runners)),
            rollout_fragment_length=train.n_steps // 4,
            env_to_module_connector=flatten_observations,
        )
        .learners(num_learners=0)
        .training(
            train_batch_size_per_learner=train.n_steps * train.num_envs // 4,
            minibatch_size=train.batch_size,
            num_epochs=epochs,
            lr=train.learning_rate,
            gamma=train.gamma,
            lambda_=train.gae_lambda,
            entropy_coeff=train.ent_coef,
            use_kl_loss=False,
            clip_param=0.2,
            vf_loss_coeff=0.5,
            grad_clip=0.5,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[width, width], vf_share_layers=False))
        # an iteration as soon as a train batch is learned (RLlib's default for APPO: 10 s at least)
        .reporting(min_time_s_per_iteration=0, min_sample_timesteps_per_iteration=0)
        .debugging(seed=train.seed)
    )


class AlgoLoop:
    """``algo.train()`` until ``steps`` more environment steps are sampled; returns steps/s."""

    def __init__(self, algo, steps: int, lags: list | None = None):
        self.algo, self.steps, self.lags = algo, steps, lags
        self.lifetime = self.lifetime_before = 0
        self.iterations = self.empty = 0  # timed iterations, and those that sampled nothing new

    def __call__(self, steps: int | None = None) -> float:
        goal, done = steps or self.steps, 0
        started = time.perf_counter()
        while done < goal:
            result = self.algo.train()
            step = max(_sampled(result), self.lifetime)
            done += step - self.lifetime
            self.lifetime = step
            if os.environ.get("APPO_PROBE_VERBOSE"):
                print(step, round(time.perf_counter() - started, 2), _lag(result), result.get("timers"))
            if steps is None:
                self.iterations += 1
                self.empty += step == self.lifetime_before
                if self.lags is not None:
                    self.lags.append(_lag(result))
            self.lifetime_before = step
        return done / (time.perf_counter() - started)

    def close(self) -> None:
        self.algo.stop()


def _sampled(result: dict) -> int:
    """Environment steps sampled so far (RLlib's lifetime count; an iteration may report none)."""
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME

    value = result.get(ENV_RUNNER_RESULTS, {}).get(NUM_ENV_STEPS_SAMPLED_LIFETIME, 0)
    return 0 if value != value else int(value)  # NaN: nothing reported yet


def _lag(result: dict) -> float | None:
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, LEARNER_RESULTS, WEIGHTS_SEQ_NO

    if os.environ.get("APPO_PROBE_VERBOSE"):
        print({k: v for k, v in result.get(ENV_RUNNER_RESULTS, {}).items() if "seq" in k})
        print(
            {
                m: {k: x for k, x in v.items() if "seq" in k}
                for m, v in result.get(LEARNER_RESULTS, {}).items()
                if isinstance(v, dict)
            }
        )
    runner = result.get(ENV_RUNNER_RESULTS, {}).get(WEIGHTS_SEQ_NO)
    learner = [v.get(WEIGHTS_SEQ_NO) for v in result.get(LEARNER_RESULTS, {}).values() if isinstance(v, dict)]
    learner = [v for v in learner if v is not None]
    if runner is None or not learner:
        return None
    return float(max(learner) - runner)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--epochs", type=int, default=1, help="APPO's passes over each train batch")
    parser.add_argument("--no-ppo", action="store_true")
    args = parser.parse_args()

    import torch
    from ray.tune.registry import register_env

    from aaai.scoring.ray_session import RaySession
    from aaai.tools.bench import _VecLoop, training_config
    from aaai.tools.rounds import alternate, load, per_round, summary
    from aaai.train.rllib_learner import ENV_NAME, _trainable_logdir, make_env, ppo_config, start_curriculum_actor

    config = training_config()
    torch.set_num_threads(1)
    logdir = tempfile.mkdtemp(prefix="aaai-appo-probe-")
    csv_path = OUT / "appo_probe.csv"
    load_before = load()
    lags: list = []
    try:
        with RaySession(None, workers=2):
            import ray

            register_env(ENV_NAME, make_env)
            runners: dict = {"env alone": _VecLoop(config, False, args.steps)}
            actors = []
            with _trainable_logdir(logdir):
                actor, name = start_curriculum_actor(config)
                actors.append(actor)
                runners["APPO"] = AlgoLoop(appo_config(config, name, 1, args.epochs).build_algo(), args.steps, lags)
                if not args.no_ppo:
                    actor, name = start_curriculum_actor(config)
                    actors.append(actor)
                    runners["PPO (rllib)"] = AlgoLoop(ppo_config(config, name, 1).build_algo(), args.steps)
            try:
                for runner in runners.values():
                    runner(1024)  # warm-up
                rates = alternate(runners, args.rounds)
            finally:
                for runner in runners.values():
                    runner.close()
                for actor in actors:
                    ray.kill(actor)
    finally:
        shutil.rmtree(logdir, ignore_errors=True)
    load_after = load()
    ratios = {
        f"{name} / env alone": per_round(rates[name], rates["env alone"]) for name in rates if name != "env alone"
    }
    known = [lag for lag in lags if lag is not None and lag == lag]  # RLlib reports NaN before a window fills
    results = {
        "settings": vars(args),
        "load": {"before": load_before, "after": load_after},
        "cpus": os.cpu_count(),
        "rates": {name: summary(values) for name, values in rates.items()},
        "ratios": {name: summary(values) for name, values in ratios.items()},
        "policy_lag": summary(known) if known else None,
        "iterations": {name: [r.iterations, r.empty] for name, r in runners.items() if isinstance(r, AlgoLoop)},
    }
    new = not csv_path.exists()
    with csv_path.open("a", newline="") as handle:
        writer = csv.writer(handle)
        if new:
            writer.writerow(["when", "epochs", "round", "runner", "steps_per_s"])
        for name, values in rates.items():
            for i, value in enumerate(values):
                writer.writerow([time.strftime("%Y-%m-%dT%H:%M:%S"), args.epochs, i, name, round(value, 1)])
    (OUT / "appo_probe.json").write_text(json.dumps(results, indent=2) + "\n")

    def fig(f: dict, digits: int = 0) -> str:
        return f"{f['median']:.{digits}f} ({f['min']:.{digits}f}..{f['max']:.{digits}f})"

    lines = [
        f"# APPO (RLlib {ray.__version__}) against the environment alone",
        "",
        f"{args.rounds} alternated rounds of {args.steps} steps; APPO {args.epochs} epoch(s) a batch; "
        f"load {load_before} -> {load_after}; {os.cpu_count()} CPUs.",
        "",
        "| | steps/s (median, min..max) | / env alone |",
        "|---|---:|---:|",
    ]
    for name, figure in results["rates"].items():
        ratio = results["ratios"].get(f"{name} / env alone")
        lines.append(f"| {name} | {fig(figure)} | {fig(ratio, 2) if ratio else ''} |")
    lag = results["policy_lag"]
    lines += [
        "",
        *(
            f"- {name}: {total} iterations (`algo.train()` calls) in the timed rounds, {empty} of them with no new "
            "sampled step"
            for name, (total, empty) in results["iterations"].items()
        ),
        "",
        "- APPO policy lag (the learner's weights_seq_no less the EnvRunner's, as RLlib reports them: means over "
        "its metrics window, in learner updates): "
        + (
            f"median {lag['median']:.1f}, {lag['min']:.0f}..{lag['max']:.0f} over {len(known)} iterations"
            if lag
            else "not reported"
        ),
    ]
    (OUT / "appo_probe.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
