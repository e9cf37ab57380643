"""L1, basic food retrieval, by running physics: the body teleported head first into each piece
eats that piece and no other and is paid its value; the yellows do not end the episode, the one
green does; all of them together pay the level's max_food_reward. Wandering pieces do wander, in
simulated time, inside the arena."""

import math

import numpy as np
import pybullet as p
import pytest

from aaai.agent.urdf_writer import HEAD_RADIUS


def now_at(env, body) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(body, physicsClientId=env.client)[0])


def head_into(env, food_body, gap: float) -> None:
    """Teleports the body so that its head is ``gap`` from touching the piece (negative: inside),
    coming at it from the arena's middle, so that the body trails behind it in the open."""
    target = now_at(env, food_body)
    radius = env.world.objects[food_body].size[0] / 2
    yaw = math.atan2(target[1], target[0])
    head_z = env.body.head_pose()[0][2]
    reach = HEAD_RADIUS + radius + gap
    across = math.sqrt(reach**2 - (head_z - target[2]) ** 2)  # the horizontal part of the reach
    head = (target[0] - across * math.cos(yaw), target[1] - across * math.sin(yaw), head_z)
    p.resetBasePositionAndOrientation(
        env.body.id, head, p.getQuaternionFromEuler((0, 0, yaw)), physicsClientId=env.client
    )


def stand(env, steps=20) -> dict:
    for _ in range(steps):
        *_, info = env.step(env.body.rest_action())
    return info


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", range(6))
def test_l1_each_piece_is_eaten_alone_pays_its_value_and_only_the_green_ends_the_episode(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 1, "difficulty": difficulty})
    assert stand(env)["food_eaten"] == 0  # no piece within reach of the start
    pieces = sorted(env.world.food, key=lambda body: env.world.food[body].kind == "food_green")  # the green last
    assert [env.world.food[b].kind for b in pieces].count("food_green") == 1
    paid = 0.0
    for count, body in enumerate(pieces, start=1):
        piece = env.world.food[body]
        head_into(env, body, -0.2)
        _, _, terminated, truncated, info = env.step(env.body.rest_action())
        assert info["food_eaten"] == count  # this piece, and no other with it
        assert info["reward_terms"]["food"] == pytest.approx(piece.food_value)
        assert info["reward_terms"]["wall"] == 0.0 and not info["fell"]
        assert terminated == (piece.kind == "food_green") and not truncated
        paid += info["reward_terms"]["food"]
        if piece.kind != "food_green":
            assert body not in env.world.food  # taken out of the world
    assert paid == pytest.approx(env.level_spec.max_food_reward)


@pytest.mark.parametrize("gap, eaten", [(-0.05, True), (0.05, False)])
def test_l1_a_piece_is_eaten_a_hair_inside_contact_and_not_a_hair_short_of_it(make_env, gap, eaten):
    env = make_env()
    env.reset(seed=4, options={"level": 1, "difficulty": 10})
    stand(env)
    still = [b for b, piece in env.world.food.items() if piece.behaviour is None]
    head_into(env, still[0], gap)
    _, _, _, _, info = env.step(env.body.rest_action())
    assert info["food_eaten"] == int(eaten)


@pytest.mark.parametrize("difficulty", [5, 10])
def test_l1_wandering_pieces_move_in_simulated_time_and_stay_in_the_arena(make_env, difficulty):
    env = make_env()
    options = {"level": 1, "difficulty": difficulty}
    seed = next(s for s in range(50) if env.reset(seed=s, options=options) and env.world.movers)
    walkers = list(env.world.movers)
    start = {body: now_at(env, body) for body in walkers}
    half = np.array(env.level_spec.arena_size) / 2
    travelled = dict.fromkeys(walkers, 0.0)
    for _ in range(250):  # 5 simulated seconds
        last = {body: now_at(env, body) for body in walkers if body in env.world.food}
        _, _, terminated, truncated, _ = env.step(env.body.rest_action())
        for body, before in last.items():
            if body in env.world.food:
                where = now_at(env, body)
                travelled[body] += float(np.linalg.norm(where[:2] - before[:2]))
                radius = env.world.objects[body].size[0] / 2
                assert (np.abs(where[:2]) <= half - radius + 1e-9).all(), (seed, where)
        if terminated or truncated:
            break
    speed = env.level_spec.objects[env.world.index[walkers[0]]].behaviour["speed"]
    for body in walkers:  # each walker went its speed for the whole time (less the steps it turned back)
        assert travelled[body] > 0.5 * speed * 5.0, (seed, body, travelled[body])
        assert not np.allclose(now_at(env, body), start[body])
