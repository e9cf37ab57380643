"""TorchRL: wrap an aaai level with ``GymEnv``, check its specs and roll out a random policy.

Shows:
  * ``torchrl.envs.GymEnv("aaai/L0-FoodContact-v0", ...)`` works directly: the Dict observation
    becomes the TensorDict entries "joints" and "rays" (the rays keep their (17, 11) grid unless
    you pass ``rays_flat=True``); configuration keys pass through as keyword arguments;
  * ``check_env_specs``, TorchRL's test that what the env returns matches its specs;
  * a random rollout of ``--steps`` steps (episodes that end inside it are reset automatically,
    the rollout carries on) and the shapes it holds, plus a ``TransformedEnv`` with the usual
    ``StepCounter`` and ``RewardSum`` transforms.

Install:  pip install -e '.[torchrl]'
Run:      python examples/torchrl_rollout.py --steps 300
"""

from __future__ import annotations

import argparse

import torch
from torchrl.envs import GymEnv, RewardSum, StepCounter, TransformedEnv
from torchrl.envs.utils import check_env_specs

import aaai  # noqa: F401  (registers aaai/AnimalAI-v0 and the per-level ids)

ENV_ID = "aaai/L0-FoodContact-v0"


def main(steps: int = 300, max_steps: int = 100, seed: int = 0):
    """Check the specs, roll out ``steps`` random steps and return the rollout TensorDict."""
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    base = GymEnv(ENV_ID, max_steps=max_steps)  # keyword arguments go to gym.make
    env = TransformedEnv(base, StepCounter())
    env.append_transform(RewardSum())
    env.set_seed(seed)
    check_env_specs(env)  # raises AssertionError if data and specs disagree

    # break_when_any_done=False: keep going across episode ends (the env is reset in place).
    rollout = env.rollout(steps, break_when_any_done=False)
    episodes_done = int(rollout["next", "done"].sum())
    print(f"rollout batch size: {tuple(rollout.batch_size)}")
    print(
        f"  joints {tuple(rollout['joints'].shape)}, rays {tuple(rollout['rays'].shape)}, "
        f"action {tuple(rollout['action'].shape)}, reward {tuple(rollout['next', 'reward'].shape)}"
    )
    print(
        f"  episodes ended inside it: {episodes_done}, "
        f"return so far of the last one: {rollout['next', 'episode_reward'][-1].item():.3f}"
    )
    env.close()
    return rollout


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300, help="length of the random rollout")
    parser.add_argument("--max-steps", type=int, default=100, help="episode length (env's max_steps)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    main(args.steps, args.max_steps, args.seed)
