"""CleanRL-style single-file PPO (continuous actions) on aaai's L0 "food contact" level.

Shows how the environment fits a hand-written training loop in the style of CleanRL's
ppo_continuous_action.py: the Dict observation flattened by ``FlattenObservation``, the usual
Gymnasium 1.x wrappers (episode statistics, action clipping, observation and reward
normalisation), ``gym.vector.SyncVectorEnv`` with its default *next-step* autoreset, and the
PPO update. Next-step autoreset: the step after an episode ends only resets that sub-env (its
action is ignored, its reward is 0), so that step is masked out of the update and the episode's
last real transition bootstraps from the true final observation when it was truncated.

Install:  pip install -e '.[train]'   (only torch is needed)
Run:      python examples/cleanrl_ppo.py --total-timesteps 512 --num-steps 128
          python examples/cleanrl_ppo.py --total-timesteps 1000000 --max-steps 1000
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
from torch.distributions.normal import Normal

import aaai  # noqa: F401  (registers aaai/AnimalAI-v0 and the per-level ids)


@dataclass
class Args:
    env_id: str = "aaai/L0-FoodContact-v0"
    """the Gymnasium id of the level"""
    max_steps: int = 200
    """episode length in control steps (the env's ``max_steps``; 0: the level's own time limit)"""
    seed: int = 1
    """seed of the experiment (torch, numpy and the level instances)"""
    total_timesteps: int = 100_000
    """total env steps of the experiment, over all envs"""
    learning_rate: float = 3e-4
    """the learning rate of the optimizer (annealed linearly to 0)"""
    num_envs: int = 2
    """the number of environments stepped together (SyncVectorEnv)"""
    num_steps: int = 1024
    """the number of steps to run in each environment per policy rollout"""
    gamma: float = 0.99
    """the discount factor gamma"""
    gae_lambda: float = 0.95
    """the lambda for the general advantage estimation"""
    num_minibatches: int = 8
    """the number of mini-batches per epoch"""
    update_epochs: int = 4
    """the K epochs to update the policy"""
    clip_coef: float = 0.2
    """the surrogate clipping coefficient"""
    ent_coef: float = 0.0
    """coefficient of the entropy"""
    vf_coef: float = 0.5
    """coefficient of the value function"""
    max_grad_norm: float = 0.5
    """the maximum norm for the gradient clipping"""


def make_env(args: Args):
    def thunk():
        kwargs = {"max_steps": args.max_steps or "auto"}
        env = gym.make(args.env_id, **kwargs)
        env = gym.wrappers.FlattenObservation(env)  # Dict('joints', 'rays') -> one vector
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        env = gym.wrappers.TransformObservation(env, lambda obs: np.clip(obs, -10, 10), None)
        env = gym.wrappers.NormalizeReward(env, gamma=args.gamma)
        env = gym.wrappers.TransformReward(env, lambda reward: np.clip(reward, -10, 10))
        return env

    return thunk


def layer_init(layer, std=np.sqrt(2), bias_const=0.0):
    torch.nn.init.orthogonal_(layer.weight, std)
    torch.nn.init.constant_(layer.bias, bias_const)
    return layer


class Agent(nn.Module):
    def __init__(self, n_obs: int, n_act: int):
        super().__init__()

        def mlp(n_out, std):
            return nn.Sequential(
                layer_init(nn.Linear(n_obs, 64)),
                nn.Tanh(),
                layer_init(nn.Linear(64, 64)),
                nn.Tanh(),
                layer_init(nn.Linear(64, n_out), std=std),
            )

        self.critic, self.actor_mean = mlp(1, 1.0), mlp(n_act, 0.01)
        self.actor_logstd = nn.Parameter(torch.zeros(1, n_act))

    def get_value(self, x):
        return self.critic(x)

    def get_action_and_value(self, x, action=None):
        mean = self.actor_mean(x)
        probs = Normal(mean, torch.exp(self.actor_logstd.expand_as(mean)))
        if action is None:
            action = probs.sample()
        return action, probs.log_prob(action).sum(1), probs.entropy().sum(1), self.critic(x)


def main(args: Args) -> list[dict]:
    """Train; return one dict of losses and statistics per iteration."""
    torch.set_num_threads(1)
    np.random.seed(args.seed)
    torch.manual_seed(args.seed)
    batch_size = args.num_envs * args.num_steps
    num_iterations = max(1, args.total_timesteps // batch_size)
    envs = gym.vector.SyncVectorEnv([make_env(args) for _ in range(args.num_envs)])  # next-step autoreset
    n_obs, n_act = envs.single_observation_space.shape[0], envs.single_action_space.shape[0]
    agent = Agent(n_obs, n_act)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)

    shape = (args.num_steps, args.num_envs)
    obs, actions = torch.zeros(shape + (n_obs,)), torch.zeros(shape + (n_act,))
    logprobs, rewards, values = torch.zeros(shape), torch.zeros(shape), torch.zeros(shape)
    terminated, done, valid = torch.zeros(shape), torch.zeros(shape), torch.zeros(shape)

    global_step, start, history = 0, time.time(), []
    next_obs = torch.tensor(envs.reset(seed=args.seed)[0], dtype=torch.float32)
    autoreset = torch.zeros(args.num_envs)  # 1 where the next step() only resets that env
    for iteration in range(1, num_iterations + 1):
        optimizer.param_groups[0]["lr"] = (1.0 - (iteration - 1.0) / num_iterations) * args.learning_rate
        returns_seen = []
        for step in range(args.num_steps):
            global_step += args.num_envs
            obs[step], valid[step] = next_obs, 1.0 - autoreset
            with torch.no_grad():
                action, logprob, _, value = agent.get_action_and_value(next_obs)
            actions[step], logprobs[step], values[step] = action, logprob, value.flatten()
            next_obs, reward, term, trunc, infos = envs.step(action.numpy())
            next_obs = torch.tensor(next_obs, dtype=torch.float32)
            rewards[step] = torch.tensor(reward, dtype=torch.float32)
            terminated[step] = torch.tensor(term, dtype=torch.float32)
            autoreset = done[step] = torch.tensor(term | trunc, dtype=torch.float32)
            if "episode" in infos:  # RecordEpisodeStatistics: raw (unnormalised) returns
                returns_seen += [float(infos["episode"]["r"][i]) for i in np.nonzero(infos["_episode"])[0]]

        # GAE over real transitions only. obs[t + 1] after a done is the episode's final
        # observation (next-step autoreset), so a truncated episode bootstraps from it.
        with torch.no_grad():
            next_value = agent.get_value(next_obs).flatten()
            advantages, lastgaelam = torch.zeros(shape), torch.zeros(args.num_envs)
            for t in reversed(range(args.num_steps)):
                nextvalues = next_value if t == args.num_steps - 1 else values[t + 1]
                delta = rewards[t] + args.gamma * nextvalues * (1.0 - terminated[t]) - values[t]
                lastgaelam = (delta + args.gamma * args.gae_lambda * (1.0 - done[t]) * lastgaelam) * valid[t]
                advantages[t] = lastgaelam
            returns = advantages + values

        b_obs, b_actions = obs.reshape(-1, n_obs), actions.reshape(-1, n_act)
        b_logprobs, b_advantages = logprobs.reshape(-1), advantages.reshape(-1)
        b_returns, b_values = returns.reshape(-1), values.reshape(-1)
        b_inds = np.nonzero(valid.reshape(-1).numpy())[0]  # mask: drop the reset-only steps
        minibatch_size = max(1, len(b_inds) // args.num_minibatches)
        clipfracs = []
        for _ in range(args.update_epochs):
            np.random.shuffle(b_inds)
            for begin in range(0, len(b_inds), minibatch_size):
                mb = b_inds[begin : begin + minibatch_size]
                _, newlogprob, entropy, newvalue = agent.get_action_and_value(b_obs[mb], b_actions[mb])
                logratio = newlogprob - b_logprobs[mb]
                ratio = logratio.exp()
                with torch.no_grad():
                    approx_kl = ((ratio - 1) - logratio).mean()
                    clipfracs.append(((ratio - 1.0).abs() > args.clip_coef).float().mean().item())
                mb_adv = b_advantages[mb]
                mb_adv = (mb_adv - mb_adv.mean()) / (mb_adv.std(unbiased=False) + 1e-8)
                pg_loss = torch.max(
                    -mb_adv * ratio, -mb_adv * torch.clamp(ratio, 1 - args.clip_coef, 1 + args.clip_coef)
                ).mean()
                newvalue = newvalue.view(-1)
                v_clipped = b_values[mb] + torch.clamp(newvalue - b_values[mb], -args.clip_coef, args.clip_coef)
                v_loss = 0.5 * torch.max((newvalue - b_returns[mb]) ** 2, (v_clipped - b_returns[mb]) ** 2).mean()
                entropy_loss = entropy.mean()
                loss = pg_loss - args.ent_coef * entropy_loss + v_loss * args.vf_coef
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()

        stats = {
            "iteration": iteration,
            "global_step": global_step,
            "policy_loss": pg_loss.item(),
            "value_loss": v_loss.item(),
            "entropy": entropy_loss.item(),
            "approx_kl": approx_kl.item(),
            "clipfrac": float(np.mean(clipfracs)),
            "masked_steps": int((valid == 0).sum()),
            "episodes": len(returns_seen),
            "mean_return": float(np.mean(returns_seen)) if returns_seen else float("nan"),
            "sps": int(global_step / (time.time() - start)),
        }
        history.append(stats)
        print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in stats.items()))
    envs.close()
    return history


def parse_args(argv=None) -> Args:
    """``--field value`` for every field of Args (CleanRL uses tyro; plain argparse here)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        parser.add_argument(
            "--" + f.name.replace("_", "-"), type=type(f.default), default=f.default, help=f"default {f.default}"
        )
    return Args(**vars(parser.parse_args(argv)))


if __name__ == "__main__":
    main(parse_args())
