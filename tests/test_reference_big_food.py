"""A big piece of food (Animal-AI's size 10, its centre 5 above the floor) is touched by the head from
above its legs: the front legs, which reach ahead of the head, meet the sphere first, so the reference
gets the head nearest crouched and then rises, lifting the head onto the piece."""

from conftest import reference_on_arena

ARENA = """arena_size: [60.0, 60.0]
time_limit: 40
agent: {x: -8.0, y: -15.0, yaw: 1.5708}
objects:
  - {kind: food_green, shape: sphere, position: [0.0, 10.0, 5.0], size: [10.0, 10.0, 10.0]}
"""


def test_a_big_piece_is_eaten_at_the_first_approach(make_env, tmp_path):
    env, controller = reference_on_arena(make_env, tmp_path, ARENA)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(controller())
    assert terminated and info["food_eaten"] == 1
    # within 9 s: crouched all the way in, it pushed at the piece with its legs for 10.6 s
    assert info["steps"] <= 450, info["steps"]
