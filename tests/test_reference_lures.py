"""The reference controller leaves alone the food an arena allows out of reach (``reach: pass_mark``,
Animal-AI's lures): it eats what it can reach, instead of pushing at a wall for a piece on a platform."""

from aaai.task.arena import load_arena
from aaai.tools.animalai_coverage import reference_episode

ARENA = """arena_size: [60.0, 60.0]
time_limit: 40
pass_mark: 1.0
reach: pass_mark
agent: {x: 0.0, y: -20.0, yaw: 1.5708}
objects:
  - {kind: wall, position: [-12.0, 15.0, 3.0], size: [16.0, 10.0, 6.0]}
  - {kind: multi_food, shape: sphere, position: [-12.0, 15.0, 7.5], size: [3.0, 3.0, 3.0]}
  - {kind: food_green, shape: sphere, position: [15.0, 5.0, 1.5], size: [3.0, 3.0, 3.0]}
"""


def test_the_reference_eats_the_food_in_reach_and_leaves_the_lure_on_a_platform(make_env, tmp_path):
    path = tmp_path / "lure.yaml"
    path.write_text(ARENA)
    spec = load_arena(path, 0)  # valid: the green alone gives the pass mark
    total, passed = reference_episode(make_env(action_mode="gait"), spec, 0)
    assert passed and total > 1.0


# the better green on the platform: the one the reference would go for, were it not out of reach
GREENS = ARENA.replace(
    "{kind: multi_food, shape: sphere, position: [-12.0, 15.0, 7.5], size: [3.0, 3.0, 3.0]}",
    "{kind: food_green, shape: sphere, position: [-12.0, 15.0, 8.0], size: [4.0, 4.0, 4.0]}",
)


def test_animal_ais_sphere_leaves_the_lure_alone_too(make_env, tmp_path):
    path = tmp_path / "lure.yaml"
    path.write_text(GREENS)
    spec = load_arena(path, 0, body="sphere")  # valid for the sphere's own footprint
    total, passed = reference_episode(make_env(action_mode="gait", body="sphere"), spec, 0)
    assert passed and total > 1.0
