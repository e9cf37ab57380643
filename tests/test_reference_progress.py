"""The reference controller counts its progress along its plan: a way round that first leads away
from the food is walked without stopping to back off (it used to count the straight-line distance,
which grows on such a way, and so backed off every few seconds as if stuck)."""

from conftest import reference_on_arena

# a wall between the start and the food, open only at its far (west) end: the way round walks away first
ARENA = """arena_size: [60.0, 60.0]
time_limit: 40
agent: {x: 8.0, y: -12.0, yaw: 1.5708}
objects:
  - {kind: wall, position: [8.0, 0.0, 2.0], size: [44.0, 2.0, 4.0]}
  - {kind: food_green, shape: sphere, position: [8.0, 10.0, 1.5], size: [3.0, 3.0, 3.0]}
"""


def test_a_way_round_that_leads_away_from_the_food_is_walked_without_backing_off(make_env, tmp_path):
    env, controller = reference_on_arena(make_env, tmp_path, ARENA)
    backed, eaten = 0, False
    for _ in range(env.unwrapped.max_steps):
        _, _, terminated, truncated, info = env.step(controller())
        backed += controller.command()[0] < 0  # a back-off: walking backward
        if terminated or truncated:
            eaten = info["food_eaten"] == 1
            break
    assert eaten
    assert backed == 0
