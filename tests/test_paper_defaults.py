"""The defaults a user gets without a config file, held to the paper's numbers (shared reference:
the paper's "Environment Design" and "Curriculum Training" sections, and the notes on the original
environment). Each number is written here as the paper gives it, never read back from
configs/default.yaml, so a default that drifts from the paper fails here and not only in a golden hash.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from aaai.config import load_config
from aaai.env import AnimalAIEnv
from aaai.train.curriculum import Curriculum


def setting(config, section: str, key: str):
    """One setting of the loaded configuration, whichever shape it has (nested, dotted or typed)."""
    if isinstance(config, dict):
        return config[section][key] if section in config else config[f"{section}.{key}"]
    return getattr(getattr(config, section), key)


@pytest.fixture(scope="module")
def config():
    return load_config()


def test_the_default_rays_are_the_papers_fan(config):
    # notes, Observations: "rays per side 1..20 (default 8, so 17 rays with the forward one), max angle
    # 5..180 degrees per side (default 45 ...), length 15"; paper, Raycast: "There is always a ray
    # pointing directly forward"
    assert setting(config, "sensors", "rays_per_side") == 8
    assert setting(config, "sensors", "ray_max_angle") == 45
    assert setting(config, "sensors", "ray_length") == 15
    env = AnimalAIEnv()
    try:
        spaces = env.observation_space
        assert isinstance(spaces, gym.spaces.Dict)
        assert spaces["rays"].shape is not None and spaces["rays"].shape[0] == 2 * 8 + 1
        # paper, The Agent: "four thighs and four legs, totaling eight joints"
        assert spaces["joints"].shape == (8,)
        # notes, Body: "Physics step 0.02 s, one decision per physics step"
        assert env.control_dt == pytest.approx(0.02)
    finally:
        env.close()


def test_the_default_camera_and_step_costs_are_the_papers(config):
    # notes, Observations: "resolution 8..512 square (default 84)"
    assert setting(config, "sensors", "camera_resolution") == 84
    # paper, Rewards: two step costs, "The first reward is received only if the head is on the ground"
    assert setting(config, "episode", "ground_penalty") is True


def test_the_default_curriculum_keeps_the_last_10_returns_of_a_cell(config):
    # paper, Curriculum Training: "A rolling moving average and variance are calculated for each cell
    # over a period of 10 episodes"; z = sigma / (|mu| + 1e-7); notes, Curriculum: "c = 0.05"
    assert setting(config, "curriculum", "window") == 10
    assert setting(config, "curriculum", "c") == 0.05
    assert setting(config, "curriculum", "spread") == "std"
    curriculum = Curriculum(
        [0, 1],
        [0],
        window=setting(config, "curriculum", "window"),
        c=setting(config, "curriculum", "c"),
        spread=setting(config, "curriculum", "spread"),
        warmup=0,
    )
    for value in range(25):
        curriculum.record(0, 0, float(value))
    last = np.arange(15, 25, dtype=float)  # the last 10 returns only
    assert list(curriculum.returns[(0, 0)]) == list(last)
    z = last.std() / (abs(last.mean()) + 1e-7)
    assert curriculum.z_scores() == pytest.approx([z, 0.0])  # fewer than two returns: z = 0
    assert curriculum.probabilities() == pytest.approx([(z + 0.05) / (z + 0.05 + 0.05), 0.05 / (z + 0.05 + 0.05)])
