"""RLlib PPO (new API stack) on aaai's L0 "food contact" level.

Shows:
  * registering the environment with ``ray.tune.registry.register_env``: the creator imports
    ``aaai`` (so the ids exist inside every Ray worker process) and calls ``gym.make``, passing
    RLlib's ``env_config`` on as keyword arguments;
  * the Dict observation ('joints', 'rays') flattened into one vector by RLlib's own
    ``FlattenObservations`` env-to-module connector, so the default MLP RLModule can take it;
  * a tiny PPO configuration (one local EnvRunner, small batches) that trains for a few
    iterations in seconds on a laptop CPU, then saves a checkpoint and shuts Ray down.

Install:  pip install -e '.[ray]'
Run:      python examples/rllib_ppo.py --iterations 2 --batch 400
          python examples/rllib_ppo.py --iterations 50 --batch 4000 --env-runners 1 --checkpoint runs/rllib_l0
"""

from __future__ import annotations

import argparse
import math
import os

ENV_ID = "aaai/L0-FoodContact-v0"
ENV_NAME = "aaai-L0"  # the name the environment is known by inside RLlib


def make_env(env_config):
    """The env creator RLlib calls in every EnvRunner (a fresh process with its own registry)."""
    import gymnasium as gym

    import aaai  # noqa: F401  (registers the aaai/... ids)

    return gym.make(ENV_ID, **dict(env_config))


def flatten_observations(env, spaces, device):
    """The env-to-module connector: Dict('joints', 'rays') -> one float vector per step."""
    from ray.rllib.connectors.env_to_module import FlattenObservations

    return FlattenObservations()


def main(
    iterations: int = 2,
    batch: int = 400,
    max_steps: int = 200,
    env_runners: int = 0,
    checkpoint: str | None = None,
    seed: int = 0,
) -> dict:
    """Train PPO for ``iterations`` iterations of ``batch`` env steps each; return the last result."""
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.tune.registry import register_env

    # Local use: only this machine's CPUs, no dashboard; the environment is single-threaded.
    ray.init(num_cpus=max(2, env_runners + 1), include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        register_env(ENV_NAME, make_env)
        config = (
            PPOConfig()  # the new API stack (RLModule, Learner, EnvRunner, ConnectorV2) is the default
            .environment(ENV_NAME, env_config={"max_steps": max_steps})
            .env_runners(
                num_env_runners=env_runners,  # 0: sample in the driver process
                num_envs_per_env_runner=1,
                rollout_fragment_length="auto",
                env_to_module_connector=flatten_observations,
            )
            .learners(num_learners=0)  # learn in the driver process, on CPU
            .training(
                train_batch_size_per_learner=batch,
                minibatch_size=min(128, batch),
                num_epochs=2,
                lr=3e-4,
                gamma=0.99,
            )
            .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[64, 64]))
            .debugging(seed=seed)
        )
        algo = config.build_algo()
        result = {}
        for i in range(iterations):
            result = algo.train()
            runners = result["env_runners"]
            learner = result["learners"]["default_policy"]
            print(
                f"iteration {i + 1}: env steps sampled {runners['num_env_steps_sampled_lifetime']}, "
                f"episode return mean {runners.get('episode_return_mean', math.nan):.3f}, "
                f"policy loss {learner['policy_loss']:.4f}"
            )
        if checkpoint:
            path = algo.save_to_path(os.path.abspath(checkpoint))
            print(f"checkpoint: {path}")
        algo.stop()
        return result
    finally:
        ray.shutdown()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=2, help="algo.train() calls")
    parser.add_argument("--batch", type=int, default=400, help="env steps per training iteration")
    parser.add_argument("--max-steps", type=int, default=200, help="episode length (env's max_steps)")
    parser.add_argument("--env-runners", type=int, default=0, help="remote EnvRunners (0: sample locally)")
    parser.add_argument("--checkpoint", default=None, help="folder to save the trained algorithm to")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    main(args.iterations, args.batch, args.max_steps, args.env_runners, args.checkpoint, args.seed)
