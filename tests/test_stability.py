"""Random actions in every level at every difficulty: the physics settings keep the body whole."""

import numpy as np
import pybullet as p
import pytest

from aaai.env import AnimalAIEnv
from aaai.levels import all_levels

SEGMENT_RADIUS = 0.5
STEPS = 200


@pytest.mark.parametrize("level", sorted(all_levels()))
def test_random_actions_never_blow_up_leave_the_arena_or_sink(level):
    env = AnimalAIEnv(level=level, rays=False)
    rng = np.random.default_rng(level)
    for difficulty in range(11):
        env.reset(seed=difficulty, options={"difficulty": difficulty})
        spec = env.level_spec
        half_x, half_y = spec.arena_size[0] / 2, spec.arena_size[1] / 2
        floor = -2.0 if spec.heightfield is not None else 0.0  # rough terrain reaches down to -2
        for _ in range(STEPS):
            _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.body.n_axes))
            assert not info["blew_up"], f"blow-up in L{level} d{difficulty}"
            if info["fell"] or terminated or truncated:
                break
            positions = [env.body.head_pose()[0]] + [
                np.array(state[0])
                for state in p.getLinkStates(env.body.id, env.body.links[1:], physicsClientId=env.client)
            ]
            for position in positions:
                assert np.all(np.isfinite(position))
                assert abs(position[0]) < half_x and abs(position[1]) < half_y, (
                    f"left the arena: L{level} d{difficulty}"
                )
                over_hole = spec.holes and position[2] < floor
                assert over_hole or position[2] > floor + SEGMENT_RADIUS * 0.5, (
                    f"a part sank into the floor: L{level} d{difficulty} z={position[2]:.2f}"
                )
    env.close()
