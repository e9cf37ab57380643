"""The last multi_food piece ends the episode (Animal-AI's GoodGoalMulti rule) as a green does: the
reference leaves it for last, and leaves it uneaten for a green worth as much or more."""

from conftest import reference_on_arena

# two gold pieces (2 each) on the way, a green (3) beyond: eating both golds would end it without the green
ARENA = """arena_size: [40.0, 40.0]
time_limit: 40
agent: {x: 0.0, y: -14.0, yaw: 1.5708}
objects:
  - {kind: multi_food, shape: sphere, position: [0.0, -6.0, 1.0], size: [2.0, 2.0, 2.0]}
  - {kind: multi_food, shape: sphere, position: [4.0, 2.0, 1.0], size: [2.0, 2.0, 2.0]}
  - {kind: food_green, shape: sphere, position: [-4.0, 10.0, 1.5], size: [3.0, 3.0, 3.0]}
"""


def test_the_last_gold_piece_is_left_for_a_green_worth_more(make_env, tmp_path):
    env, controller = reference_on_arena(make_env, tmp_path, ARENA)
    total = 0.0
    for _ in range(env.unwrapped.max_steps):
        _, reward, terminated, truncated, info = env.step(controller())
        total += reward
        if terminated or truncated:
            break
    assert terminated and info["food_eaten"] == 2, (total, info["food_eaten"], info["steps"])
    assert total > 4.5  # a gold piece (2) and the green (3); both gold pieces would give less than 4
