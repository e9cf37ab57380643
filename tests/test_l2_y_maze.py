"""L2, preferences (Y-maze), by running physics: the body teleported head first into the larger
green (in the arm the level's extras name as best_arm) is paid its value, which is the level's
max_food_reward, and the episode ends there; above difficulty 5 a smaller green pays less, also
ends the episode (only one green can be eaten), and lies in the other arm: a ray from one green to
the other is stopped by the wall between the arms. The maze's walls are solid: the body pushed
into one stays on its side of it."""

import math

import numpy as np
import pybullet as p
import pytest
from test_l1_foods import head_into

from aaai.agent.urdf_writer import HEAD_RADIUS, SEGMENT_RADIUS
from aaai.levels import validate
from aaai.spec.kinds import KIND_INDEX

SEEDS = (0, 1, 2)


def greens(env) -> list[int]:
    """The level's green pieces, the larger first."""
    pieces = sorted(env.world.food, key=lambda body: -env.world.food[body].size[0])
    assert all(env.world.food[body].kind == "food_green" for body in pieces)
    return pieces


def maze_walls(env) -> list:
    """The walls of the maze itself (the stem's two sides and the wall between the arms), not the arena's."""
    half = np.array(env.level_spec.arena_size) / 2
    return [o for o in env.world.objects.values() if o.kind == "wall" and (np.abs(o.position[:2]) < half - 1.0).all()]


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", SEEDS)
def test_l2_each_green_eaten_ends_the_episode_and_only_the_larger_pays_the_levels_best(make_env, difficulty, seed):
    env = make_env()
    options = {"level": 2, "difficulty": difficulty}
    env.reset(seed=seed, options=options)
    assert validate.check(env.level_spec) == []  # every green reachable from the start
    count = len(greens(env))
    assert count == (2 if difficulty > 5 else 1)
    best = env.world.objects[greens(env)[0]].position
    assert np.sign(best[0]) == {"east": 1, "west": -1}[env.level_spec.extras["best_arm"]]  # the arm the level names
    paid = []
    for rank in range(count):  # each green in a fresh episode: the larger, then the smaller
        env.reset(seed=seed, options=options)
        body = greens(env)[rank]
        value = env.world.food[body].food_value
        head_into(env, body, -0.2)
        _, reward, terminated, truncated, info = env.step(env.body.rest_action())
        assert info["food_eaten"] == 1 and terminated and not truncated  # one green, and the episode is over
        assert info["reward_terms"]["food"] == pytest.approx(value)
        assert info["reward_terms"]["wall"] == 0.0 and not info["fell"]
        paid.append(info["reward_terms"]["food"])
    assert paid[0] == pytest.approx(env.level_spec.max_food_reward)  # the larger is the best there is
    assert all(other < paid[0] - 0.5 for other in paid[1:])  # the smaller clearly pays less


@pytest.mark.parametrize("difficulty", [6, 8, 10])
@pytest.mark.parametrize("seed", SEEDS)
def test_l2_above_5_the_two_greens_lie_in_different_arms_with_a_wall_between(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 2, "difficulty": difficulty})
    large, small = (env.world.objects[body].position for body in greens(env))
    height = min(large[2], small[2])  # both centres are below the walls' tops
    hit = p.rayTest((*large[:2], height), (*small[:2], height), physicsClientId=env.client)[0]
    assert hit[0] >= 0 and env.world.kind_index[hit[0]] == KIND_INDEX["wall"], (large, small)
    wall = env.world.objects[hit[0]]
    assert wall in maze_walls(env)  # the maze's own, not the arena's
    assert abs(hit[3][0] - wall.position[0]) == pytest.approx(wall.size[1] / 2)  # stopped at its face


def gap(env, centre: np.ndarray, outward: np.ndarray) -> float:
    """How far the body's nearest part is from a line through ``centre`` (a wall's middle line),
    measured along ``outward`` (the wall's normal toward the body): the head's sphere and each leg's
    two capsules, whose axes run hip to knee and knee to a cap's radius short of the foot."""
    head = env.body.head_pose()[0]
    nearest = (head[:2] - centre) @ outward - HEAD_RADIUS
    for hip, knee, foot in env.body.leg_points():
        shin_end = foot - SEGMENT_RADIUS * (foot - knee) / np.linalg.norm(foot - knee)
        for point in (hip, knee, shin_end):
            nearest = min(nearest, (point[:2] - centre) @ outward - SEGMENT_RADIUS)
    return float(nearest)


@pytest.mark.parametrize("difficulty", [0, 10])
def test_l2_the_body_pushed_into_a_maze_wall_stays_on_its_side(make_env, difficulty):
    env = make_env()
    env.reset(seed=1, options={"level": 2, "difficulty": difficulty})
    assert len(maze_walls(env)) == 3
    for index in range(3):
        env.reset(seed=1, options={"level": 2, "difficulty": difficulty})
        wall = maze_walls(env)[index]
        normal = np.array([-math.sin(wall.yaw), math.cos(wall.yaw)])  # across the wall's thickness
        centre = np.array(wall.position[:2])
        side = -np.sign(centre @ normal) or 1.0  # the side toward the arena's middle line (east of the divider)
        start = centre + side * normal * (wall.size[1] / 2 + 5.0)  # clear of it, legs and all
        p.resetBasePositionAndOrientation(
            env.body.id,
            (*start, 1.5),
            p.getQuaternionFromEuler((0, 0, math.atan2(-side * normal[1], -side * normal[0]))),
            physicsClientId=env.client,
        )
        push = (*(-side * normal * 300.0), 0.0)
        gaps = []
        for _ in range(100):  # two simulated seconds of a hard push into the wall
            head = env.body.head_pose()[0]
            p.applyExternalForce(env.body.id, -1, push, head.tolist(), p.WORLD_FRAME, physicsClientId=env.client)
            env.step(env.body.rest_action())
            gaps.append(gap(env, centre, side * normal) - wall.size[1] / 2)  # negative: some part inside the wall
        assert min(gaps) > -0.05, (wall.position, min(gaps))  # against it at most, never into it
        assert gaps[-1] < 0.05, (wall.position, gaps[-1])  # it was pushed up against it
        assert side * (env.body.head_pose()[0][:2] - centre) @ normal > wall.size[1] / 2 + HEAD_RADIUS  # on its side
