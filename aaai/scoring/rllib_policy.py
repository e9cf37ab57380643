"""A policy trained by ``aaai train --backend rllib``, loaded from its checkpoint for scoring (only
when trusted or signed on this machine, :mod:`aaai.scoring.rllib_checkpoints`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gymnasium.spaces import MultiDiscrete

from aaai.scoring.model_io import in_float64
from aaai.scoring.rllib_checkpoints import check_rllib_checkpoint
from aaai.scoring.runs import MODULE_PATH, rllib_checkpoint


class RLlibPolicy:
    """A policy trained by ``aaai train --backend rllib``, acting deterministically (the mean
    action; with discrete actions each part's likeliest choice), as the scoreboard's policies do:
    ``policy(observation) -> action`` for an environment with the run's observations. The
    observation is flattened as RLlib's FlattenObservations connector does it."""

    def __init__(self, checkpoint: str | Path, env, trust: bool = False):
        import torch
        from ray.rllib.core.rl_module.rl_module import RLModule
        from ray.rllib.utils.spaces.space_utils import get_base_struct_from_space

        self.torch = torch
        folder = rllib_checkpoint(checkpoint)
        check_rllib_checkpoint(folder, trust)  # pickles: only trusted or signed on this machine
        self.module = RLModule.from_checkpoint(str((folder / MODULE_PATH).absolute()))
        self.dtype: type[np.floating] = np.float32
        if isinstance(self.module, torch.nn.Module):
            self.module.eval()  # inference: as RLlib's own inference does
            in_float64(self.module)
            self.dtype = np.float64
        self.structure = get_base_struct_from_space(env.observation_space)
        self.space = env.action_space

    def reset(self, seed: int) -> None:
        pass

    def __call__(self, observation):
        from ray.rllib.utils.numpy import flatten_inputs_to_1d_tensor

        flat = flatten_inputs_to_1d_tensor(observation, spaces_struct=self.structure, batch_axis=False)
        with self.torch.no_grad():
            out = self.module.forward_inference({"obs": self.torch.as_tensor(np.asarray(flat, self.dtype)[None])})
        inputs = out["action_dist_inputs"][0].numpy()
        if isinstance(self.space, MultiDiscrete):  # each part's logits in turn: its likeliest choice
            bounds = np.cumsum(self.space.nvec)[:-1]
            return np.array([int(np.argmax(part)) for part in np.split(inputs, bounds)], np.int64)
        mean = inputs[: self.space.shape[0]]  # a diagonal Gaussian: means, log stds
        squashed = np.clip(mean, -1.0, 1.0)  # RLlib's unsquash_action: [-1, 1] onto the space's bounds
        return self.space.low + (squashed + 1.0) * (self.space.high - self.space.low) / 2.0  # float64: put on the grid
