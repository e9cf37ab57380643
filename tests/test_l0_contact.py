"""L0, food contact, as a probe by running physics: the piece of whatever size the difficulty gives
it, teleported in front of the head a hair inside or outside touching distance, is eaten or not."""

import numpy as np
import pytest

from aaai.agent.urdf_writer import HEAD_RADIUS


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("gap, eaten", [(-0.02, True), (0.02, False)])
def test_l0_food_is_eaten_on_contact_with_the_head_and_not_a_hair_short_of_it(make_env, difficulty, gap, eaten):
    """The L0 piece, of whatever size the difficulty gives it, put in front of the head a hair
    inside or outside touching distance (head radius plus its own), then one step at rest."""
    env = make_env()
    env.reset(seed=3, options={"level": 0, "difficulty": difficulty})
    (body,) = env.unwrapped.world.food
    radius = env.unwrapped.world.food[body].size[0] / 2
    head, rotation = env.unwrapped.body.head_pose()
    forward = np.array([rotation[0, 0], rotation[1, 0], 0.0])
    forward /= np.linalg.norm(forward)
    env.unwrapped.world.place(body, tuple(head + forward * (HEAD_RADIUS + radius + gap)), 0.0)
    _, reward, terminated, _, info = env.step(env.unwrapped.body.rest_action())
    assert info["food_eaten"] == int(eaten) and terminated == eaten
    if eaten:  # the level's whole reward, less one step's time cost
        assert reward == pytest.approx(env.unwrapped.level_spec.max_food_reward, abs=0.01)
