"""Stable-Baselines3 PPO on aaai's L0 "food contact" level.

Shows:
  * ``gym.make("aaai/L0-FoodContact-v0", rays_flat=True, ...)``: configuration keys as keyword
    arguments; ``rays_flat=True`` gives the rays as one vector, so SB3's ``check_env`` passes
    without warnings (it warns about the default (17, 11) ray grid);
  * SB3's ``check_env`` on the environment before training;
  * PPO with ``MultiInputPolicy`` (the observation is a Dict: 'joints' and 'rays'), trained for
    ``--steps`` steps on two vectorised copies of the level, saved to a .zip, loaded back and
    evaluated for a couple of episodes with ``evaluate_policy``.

Install:  pip install -e '.[train]'
Run:      python examples/sb3_ppo.py --steps 256 --out /tmp/sb3_l0
          python examples/sb3_ppo.py --steps 200000 --max-steps auto --out runs/sb3_l0
"""

from __future__ import annotations

import argparse
import os

import gymnasium as gym
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor

import aaai  # noqa: F401  (registers aaai/AnimalAI-v0 and the per-level ids)

ENV_ID = "aaai/L0-FoodContact-v0"


def main(
    steps: int = 256, out: str = "runs/sb3_l0", max_steps: int | str = 200, eval_episodes: int = 2, seed: int = 0
) -> tuple[str, float, float]:
    """Check, train, save, reload and evaluate; return (model path, mean return, std)."""
    torch.set_num_threads(1)
    env_kwargs = {"rays_flat": True, "max_steps": max_steps}

    env = gym.make(ENV_ID, **env_kwargs)
    check_env(env.unwrapped)  # raises on an API error; warns on anything SB3 cannot use well
    env.close()

    vec_env = make_vec_env(ENV_ID, n_envs=2, seed=seed, env_kwargs=env_kwargs)
    n_steps = max(8, min(1024, steps // 2))  # rollout length per env, so `steps` is >= one rollout
    model = PPO(
        "MultiInputPolicy",
        vec_env,
        n_steps=n_steps,
        batch_size=min(64, 2 * n_steps),
        n_epochs=4,
        gamma=0.99,
        seed=seed,
        device="cpu",
        verbose=0,
    )
    model.learn(total_timesteps=steps)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "ppo_l0.zip")
    model.save(path)
    vec_env.close()

    model = PPO.load(path, device="cpu")
    eval_env = Monitor(gym.make(ENV_ID, **env_kwargs))  # Monitor: true episode returns
    mean, std = evaluate_policy(model, eval_env, n_eval_episodes=eval_episodes, deterministic=True)
    eval_env.close()
    print(
        f"trained {model.num_timesteps} steps, saved {path}; "
        f"evaluation over {eval_episodes} episodes: {mean:.3f} +- {std:.3f}"
    )
    return path, float(mean), float(std)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=256, help="training env steps")
    parser.add_argument("--out", default="runs/sb3_l0", help="folder for ppo_l0.zip")
    parser.add_argument(
        "--max-steps", default="200", help="episode length in steps, or 'auto' for the level's own time limit"
    )
    parser.add_argument("--eval-episodes", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    max_steps = args.max_steps if args.max_steps == "auto" else int(args.max_steps)
    main(args.steps, args.out, max_steps, args.eval_episodes, args.seed)
