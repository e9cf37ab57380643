"""Rewards and episode ends, tested by running physics."""

import math

import numpy as np
import pybullet as p
import pytest
from conftest import open_arena, sphere

from aaai.sim.gait import SineGait
from aaai.spec import ObjectSpec


def walk_until(env, spec, predicate, steps=600):
    observation, _ = env.reset(options={"spec": spec})
    gait = SineGait.for_env(env, "forward")
    history = []
    for _ in range(steps):
        observation, reward, terminated, truncated, info = env.step(gait(observation))
        history.append((reward, terminated, truncated, info))
        if predicate(info) or terminated or truncated:
            break
    return history


def test_green_food_eaten_by_the_head_pays_its_size_and_ends_the_episode(make_env):
    env = make_env(limb_food_reward="none", max_steps=1000)
    spec = open_arena(sphere("food_green", 5.0, 0.0, 2.0))
    history = walk_until(env, spec, lambda info: False)
    reward, terminated, truncated, info = history[-1]
    assert terminated and not truncated
    assert info["reward_terms"]["food"] == 2.0 and info["food_eaten"] == 1
    assert reward == pytest.approx(2.0 + sum(v for k, v in info["reward_terms"].items() if k != "food"))
    assert info["max_reward"] == pytest.approx(2.0 - 0.5)


def test_yellow_food_pays_half_its_size_disappears_and_the_episode_goes_on(make_env):
    env = make_env(limb_food_reward="none")
    spec = open_arena(sphere("food_yellow", 5.0, 0.0, 3.0), sphere("food_yellow", -15.0, 15.0, 2.0))
    history = walk_until(env, spec, lambda info: info["food_eaten"] > 0)
    reward, terminated, truncated, info = history[-1]
    assert info["reward_terms"]["food"] == 1.5 and not terminated
    assert len(env.world.food) == 1  # the piece is gone, the other is left
    _, _, terminated, _, info = env.step(np.zeros(8))
    assert not terminated and info["reward_terms"]["food"] == 0.0


def test_eating_the_last_piece_ends_the_episode(make_env):
    env = make_env(limb_food_reward="none")
    history = walk_until(env, open_arena(sphere("food_yellow", 5.0, 0.0, 3.0)), lambda info: info["food_eaten"] > 0)
    _, terminated, truncated, info = history[-1]
    assert info["reward_terms"]["food"] == 1.5 and terminated and not truncated


def test_a_level_without_food_runs_to_its_time_limit(make_env):
    env = make_env(max_steps=30)
    env.reset(options={"spec": open_arena()})
    for step in range(30):
        _, _, terminated, truncated, _ = env.step(env.body.rest_action())
        assert not terminated
    assert truncated


def test_a_leg_touching_food_pays_the_flat_limb_reward(make_env):
    env = make_env(limb_food_reward="flat")
    # The front-left leg lies along the diagonal; a piece resting on its shin is touched at once.
    spec = open_arena(ObjectSpec("food_green", "sphere", (2.6, 2.6, 2.45), (1.0, 1.0, 1.0)))
    env.reset(options={"spec": spec, "check": False})  # food floating over the leg is no valid level
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert terminated and info["reward_terms"]["food"] == 1.0


def test_each_new_wall_contact_costs_one(make_env):
    env = make_env()
    wall = ObjectSpec("wall", "box", (7.0, 0.0, 2.0), (1.0, 20.0, 4.0))
    history = walk_until(env, open_arena(wall), lambda info: False, steps=300)
    wall_terms = [info["reward_terms"]["wall"] for *_, info in history]
    hits = history[-1][3]["wall_hits"]
    assert hits >= 1
    assert sum(wall_terms) == -hits  # one -1 per new contact, none while a contact lasts
    assert min(wall_terms) >= -8  # at most one per body part


def test_transparent_walls_cost_nothing(make_env):
    env = make_env()
    glass = ObjectSpec("transparent_wall", "box", (7.0, 0.0, 2.0), (1.0, 20.0, 4.0))
    history = walk_until(env, open_arena(glass), lambda info: False, steps=300)
    assert all(info["reward_terms"]["wall"] == 0 for *_, info in history)
    position, _ = env.body.head_pose()
    assert position[0] < 7.0  # it still stops the body


def test_falling_onto_the_deadly_floor_costs_one_and_ends_the_episode(make_env):
    env = make_env()
    spec = open_arena(tiles=(5, 5), holes=((2, 2),))  # the centre tile, under the agent, is missing
    observation, _ = env.reset(options={"spec": spec, "check": False})  # no valid level: run it all the same
    for step in range(200):
        observation, reward, terminated, truncated, info = env.step(env.body.rest_action())
        if terminated:
            break
    assert terminated and not truncated
    assert info["fell"] and info["reward_terms"]["fall"] == -1.0


def test_step_costs_with_and_without_the_ground_penalty(make_env):
    env = make_env(max_steps=100)
    env.reset(options={"spec": open_arena()})
    _, reward, *_, info = env.step(env.body.rest_action())  # lying at rest: the head is on the floor
    assert info["reward_terms"]["ground"] == -0.005 and reward == pytest.approx(-0.01)
    flat = make_env(max_steps=100, ground_penalty=False)
    flat.reset(options={"spec": open_arena()})
    for action in (np.full(8, 0.9, np.float32),) * 30:  # pushed up off the head
        _, reward, *_, info = flat.step(action)
    assert reward == pytest.approx(-0.01)


def test_reaching_max_steps_truncates(make_env):
    env = make_env(max_steps=10)
    env.reset(seed=0)
    for step in range(10):
        _, _, terminated, truncated, info = env.step(np.zeros(8))
    assert truncated and not terminated and info["steps"] == 10


def test_a_physics_blow_up_is_caught_and_truncates(make_env):
    env = make_env()
    env.reset(seed=0)
    p.resetBaseVelocity(env.body.id, [1e4, 0, 0], physicsClientId=env.client)
    _, _, terminated, truncated, info = env.step(np.zeros(8))
    assert truncated and not terminated and info["blew_up"]


@pytest.mark.parametrize("level", [0, 1])
@pytest.mark.parametrize("body", ["quadruped", "quadruped16"])
def test_random_actions_keep_the_body_whole_and_in_the_arena(make_env, level, body):
    env = make_env(body=body, action_mode="rotation")
    rng = np.random.default_rng(level)
    for difficulty in (0, 5, 10):
        env.reset(seed=difficulty, options={"level": level, "difficulty": difficulty})
        for _ in range(250):
            _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.body.n_axes))
            assert not info["blew_up"]
            parts = [env.body.head_pose()[0]] + [
                np.array(s[0]) for s in p.getLinkStates(env.body.id, env.body.links[1:], physicsClientId=env.client)
            ]
            for position in parts:
                assert np.all(np.isfinite(position))
                assert abs(position[0]) < 25 and abs(position[1]) < 25  # inside the walls
                assert position[2] > 0.0  # above the floor's top
            if terminated or truncated:
                break


def test_shaping_pays_the_progress_towards_food_and_is_off_by_default(make_env):
    spec = open_arena(sphere("food_green", 12.0, 0.0, 2.0))
    plain = make_env()
    plain.reset(options={"spec": spec})
    _, _, _, _, info = plain.step(plain.body.rest_action())
    assert info["reward_terms"]["shaping"] == 0.0
    env = make_env(shaping=2.0)
    observation, _ = env.reset(options={"spec": spec})
    start = env.task.food_distance
    gait = SineGait.for_env(env, "forward")
    total = 0.0
    for _ in range(150):
        observation, _, terminated, _, info = env.step(gait(observation))
        total += info["reward_terms"]["shaping"]
    head, _ = env.body.head_pose()
    assert env.task.food_distance == pytest.approx(math.dist(head[:2], (12.0, 0.0)), abs=1e-6)
    assert total == pytest.approx(2.0 * (start - env.task.food_distance))  # with gamma 1 the potential telescopes
    assert total > 4.0  # the gait walked towards the food


# A piece of food resting on the front-left shin (the leg lies along the diagonal), away from the head,
# touched at the first step; with a size of 1.5 the three limb modes pay three different amounts.
ON_THE_LEG = (2.6, 2.6, 2.6)


@pytest.mark.parametrize("mode, paid", [("none", 0.0), ("flat", 1.0), ("size", 1.5)])
def test_a_leg_touching_green_food_pays_as_limb_food_reward_says(make_env, mode, paid):
    env = make_env(limb_food_reward=mode)
    spec = open_arena(ObjectSpec("food_green", "sphere", ON_THE_LEG, (1.5, 1.5, 1.5)))
    env.reset(options={"spec": spec, "check": False})  # food floating over the leg is no valid level
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert info["reward_terms"]["food"] == paid
    eaten = mode != "none"  # with none the leg does not eat: the piece stays and the episode goes on
    assert terminated == eaten and info["food_eaten"] == int(eaten)


@pytest.mark.parametrize("mode, paid", [("none", 0.0), ("flat", 0.5), ("size", 0.75)])
def test_a_leg_touching_yellow_food_pays_as_limb_food_reward_says_and_eats_it(make_env, mode, paid):
    env = make_env(limb_food_reward=mode)
    spec = open_arena(
        ObjectSpec("food_yellow", "sphere", ON_THE_LEG, (1.5, 1.5, 1.5)), sphere("food_yellow", -15.0, 15.0, 2.0)
    )  # another piece: eating one does not end it
    env.reset(options={"spec": spec, "check": False})
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert info["reward_terms"]["food"] == paid and not terminated
    assert info["food_eaten"] == (0 if mode == "none" else 1)
    _, _, terminated, _, info = env.step(env.body.rest_action())  # an eaten piece is gone: nothing more
    assert info["reward_terms"]["food"] == 0.0 and not terminated
    assert info["food_eaten"] == (0 if mode == "none" else 1)


def test_shaping_gamma_discounts_the_distance_now(make_env):
    """shaping = k x (distance before - gamma x distance now), distances from the head to the food's centre."""
    k, gamma, food = 2.0, 0.9, (12.0, 0.0)
    env = make_env(shaping=k, shaping_gamma=gamma)
    observation, _ = env.reset(options={"spec": open_arena(sphere("food_green", *food, 2.0))})

    def distance():
        return math.dist(env.body.head_pose()[0][:2], food)

    before = distance()
    gait = SineGait.for_env(env, "forward")
    paid = []
    for _ in range(60):
        observation, _, terminated, _, info = env.step(gait(observation))
        now = distance()
        paid.append(info["reward_terms"]["shaping"])
        assert paid[-1] == pytest.approx(k * (before - gamma * now), abs=1e-6)
        before = now
    assert sum(paid) > k * (1 - gamma) * 9.0 * len(paid)  # 10 units away, each step pays about 2
    standing = make_env(shaping=k)  # gamma 1: standing still far from the food pays next to nothing
    standing.reset(options={"spec": open_arena(sphere("food_green", *food, 2.0))})
    for _ in range(10):
        _, _, _, _, info = standing.step(standing.body.rest_action())
    assert abs(info["reward_terms"]["shaping"]) < 0.05


def test_walking_on_a_wall_top_is_footing_and_costs_nothing(make_env):
    # a raised floor 3 high under the start (the body is spawned on its top), wide enough to walk on
    env = make_env()
    top = ObjectSpec("wall", "box", (0.0, 0.0, 1.5), (40.0, 40.0, 3.0))
    history = walk_until(env, open_arena(top), lambda info: False, steps=80)
    assert env.body.head_pose()[0][2] > 3.0  # on the top, walking
    assert all(info["reward_terms"]["wall"] == 0 for *_, info in history)
    assert history[-1][3]["wall_hits"] == 0
