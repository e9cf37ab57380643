"""The searching reference (aaai.task.search): it knows food only once the agent's rays have hit it,
goes to it once seen, and looks round and explores when it has seen none."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from aaai.config import ConfigError, load_config
from aaai.env import AnimalAIEnv
from aaai.scoring.episodes import PASS_RATIO, play
from aaai.task.search import (
    HOLD_DETOUR,
    HOLD_MARGIN,
    INTERCEPT_SPEED,
    SearchController,
    StrictSearchController,
    ThoroughSearchController,
)


def _place(env, x: float, y: float, yaw: float) -> dict:
    """The body set down at (x, y) facing ``yaw``; one standing decision so the rays cast from there."""
    p.resetBasePositionAndOrientation(
        env.body.id, (x, y, 1.5), p.getQuaternionFromEuler((0, 0, yaw)), physicsClientId=env.client
    )
    return env.step(np.zeros(3))[0]


def _yaw(env) -> float:
    rotation = env.body.head_pose()[1]
    return math.atan2(rotation[1, 0], rotation[0, 0])


def _rays_hit(env, body: int) -> bool:
    return any(hit[0] == body for hit in env.rays.last[2])


def test_food_behind_the_body_is_unknown_until_a_ray_hits_it_and_then_it_is_eaten(gait_env):
    """L0 d0: set down 6 units from the food facing away, it does not know the food; it knows it from
    the first decision a ray hits it (never before), and then walks to it and eats it."""
    env = gait_env
    controller = SearchController(env)
    env.reset(seed=1, options={"level": 0, "difficulty": 0})
    controller.reset(1)
    (food,) = env.world.food
    x, y, _ = env.world.food[food].position
    observation = _place(env, x, y - 6.0, -math.pi / 2)  # the food straight behind
    assert not _rays_hit(env, food)
    ever_hit = False
    for decision in range(200):
        ever_hit = ever_hit or _rays_hit(env, food)
        action = controller(observation)
        assert (food in controller.memory) == ever_hit, decision
        observation, _, terminated, _, info = env.step(action)
        if terminated:
            break
    assert ever_hit and info["food_eaten"] == 1, decision


def test_a_piece_gone_from_where_the_rays_should_show_it_is_forgotten_and_looked_for(gait_env):
    """L0 d0: seen 6 units ahead, then moved (by hand) out of the rays' view: the next cast passes
    where it was without hitting it, so the piece is forgotten and the body looks round again."""
    env = gait_env
    controller = SearchController(env)
    env.reset(seed=1, options={"level": 0, "difficulty": 0})
    controller.reset(1)
    (food,) = env.world.food
    x, y, z = env.world.food[food].position
    observation = _place(env, x, y - 6.0, math.pi / 2)  # facing it
    controller(observation)
    assert food in controller.memory and not controller.looking
    p.resetBasePositionAndOrientation(food, (x, y - 12.0, z), (0, 0, 0, 1), physicsClientId=env.client)  # behind
    observation = env.step(np.zeros(3))[0]
    controller(observation)
    assert food not in controller.memory and controller.looking
    assert controller.hint is not None and math.dist(controller.hint, (x, y)) < 1.0


def test_with_nothing_seen_it_looks_round_on_the_spot_then_walks_to_unswept_space(gait_env):
    """L5 d0: the food is far behind walls. First it turns on the spot (over half a turn in
    3.5 s, never commanding a step forward); then it walks off, into space its rays had not swept."""
    env = gait_env
    controller = SearchController(env)
    observation, _ = env.reset(seed=1, options={"level": 5, "difficulty": 0})
    controller.reset(1)
    start = env.body.head_pose()[0][:2]
    turned, last = 0.0, _yaw(env)
    for _ in range(35):
        action = controller(observation)
        assert action[0] == 0.0  # no step forward: on the spot
        observation = env.step(action)[0]
        turned += abs(math.remainder(_yaw(env) - last, 2 * math.pi))
        last = _yaw(env)
    assert turned > math.pi and np.linalg.norm(env.body.head_pose()[0][:2] - start) < 1.0
    swept_after_look = controller.seen.copy()
    visited = set()
    for _ in range(85):
        observation = env.step(controller(observation))[0]
        head = env.body.head_pose()[0]
        visited.add((round(head[0] / 2), round(head[1] / 2)))
    assert not controller.memory  # no food seen, all the while
    assert np.linalg.norm(env.body.head_pose()[0][:2] - start) > 8.0
    assert len(visited) > 5
    assert controller.seen.sum() > 1.3 * swept_after_look.sum()


def test_an_l0_episode_with_the_food_behind_the_start_is_passed_by_searching(gait_env):
    """L0 d3, the body set down in the middle of the arena facing away from the food (4 units
    behind it, out of every ray): the search finds it and eats it well within the time limit."""
    env = gait_env
    controller = SearchController(env)
    env.reset(seed=1, options={"level": 0, "difficulty": 3})
    controller.reset(1)
    (food,) = env.world.food
    fx, fy, _ = env.world.food[food].position
    observation = _place(env, 0.0, 0.0, math.atan2(-fy, -fx))  # facing away
    assert not _rays_hit(env, food)
    for decision in range(env.max_steps // env.hold):
        observation, _, terminated, truncated, info = env.step(controller(observation))
        if terminated or truncated:
            break
    assert info["food_eaten"] == 1 and terminated and decision < 150, decision


@pytest.mark.parametrize("teacher", ["search", "search_strict", "search_thorough"])
def test_a_search_teacher_teaches_a_student_that_drives_part_of_the_time(teacher):
    """``train.teacher: search`` (and ``search_strict``, ``search_thorough``) in a DAgger round with the
    student driving about half the time:
    every decision is labelled, some by the student's actions, and bad teachers are refused."""
    pytest.importorskip("stable_baselines3", reason="needs the train extra")
    from aaai.train.student import Job, build_policy, check_teachable, play_job

    config = load_config(
        {
            "agent": {"action_mode": "gait"},
            "curriculum": {"levels": "5", "difficulties": "0"},
            "train": {"teacher": teacher, "num_envs": 1, "net_width": 16},
        }
    )
    check_teachable(config)
    env = AnimalAIEnv(config=config.env_dict())
    weights = build_policy(env.observation_space, env.action_space, 16).state_dict()
    env.close()
    gathered = play_job(Job(config, weights, 16, 0.5, 1, ((5, 0, 7),), cap=40))
    assert len(gathered["labels"]) == 40 and 0 < gathered["taught"] < 40
    assert tuple(gathered["labels"][0]) == (0.0, 1.0, 1.0)  # the search teacher's: it looks round, head low
    assert np.isfinite(gathered["labels"]).all()
    with pytest.raises(ConfigError, match="train.teacher.*'serch'.*reference, search"):
        load_config({"train": {"teacher": "serch"}})


def test_without_rays_the_search_is_refused_naming_the_key():
    env = AnimalAIEnv(config={"sensors": {"rays": False}})
    try:
        with pytest.raises(ConfigError, match="sensors.rays"):
            SearchController(env)
    finally:
        env.close()


def test_a_new_exploration_goal_lies_the_way_the_body_faces(gait_env):
    """L5 d0, nothing seen: set down in the open facing east and then west, the first place it
    chooses to explore lies ahead of it each time (less than a right angle off its heading), so that
    the way it goes follows from where it faces, as a student sees it."""
    env = gait_env
    for yaw in (0.0, math.pi):
        controller = SearchController(env)
        env.reset(seed=1, options={"level": 5, "difficulty": 0})
        controller.reset(1)
        _place(env, 12.0, -15.0, yaw)  # in the open half, 17 from the walls east and west
        controller._start_episode()
        controller.looking = False
        head = env.body.head_pose()[0]
        goal = controller._explore_goal(head)
        bearing = math.atan2(goal[1] - head[1], goal[0] - head[0])
        assert abs(math.remainder(bearing - _yaw(env), 2 * math.pi)) < math.pi / 2, (yaw, goal)


def _cell(env, x: float, y: float) -> tuple[int, int]:
    from aaai.levels import validate

    return validate.cell(env.level_spec, x, y, validate.blocked_grid(env.level_spec).shape)


def test_the_strict_search_knows_a_wall_once_a_ray_hits_it_or_the_body_meets_it(gait_env):
    """L2 d0 (the Y-maze; the divider between the arms runs from y = 3 to the north wall). The strict
    searching reference plans as if no wall stood until its senses show one: facing the divider's end
    from 6 units off, the cells a ray hit are walls to it and the divider's far part is still free
    (the searching reference knows all of it); set down with its head about 2 units from a stem wall, facing away, the
    body feels that wall."""
    env = gait_env
    strict, knowing = StrictSearchController(env), SearchController(env)
    observation, _ = env.reset(seed=1, options={"level": 2, "difficulty": 0})
    strict.reset(1)
    knowing.reset(1)
    observation = _place(env, 0.0, -3.0, math.pi / 2)
    strict(observation)
    knowing(observation)
    near_end, far = _cell(env, 0.0, 3.2), _cell(env, 0.0, 20.0)
    assert strict.grid[near_end] == 1 and strict.grid[far] == 0
    assert knowing.grid[near_end] == 1 and knowing.grid[far] == 1
    assert strict.walk[_cell(env, 0.0, 12.0)] and not knowing.walk[_cell(env, 0.0, 12.0)]
    stem = _cell(env, 7.5, -20.0)  # the east stem wall, under no ray yet
    assert strict.grid[stem] == 0
    observation = _place(env, 5.8, -20.0, math.pi)  # the head about 2 from its face (x = 7), facing west
    strict(observation)
    assert strict.grid[stem] == 1


def test_the_strict_search_finds_food_behind_walls_it_learns_on_the_way(gait_env):
    """L5 d0 seed 2 (the food behind a wall): the strict searching reference eats it within the time
    limit without once touching a wall, and ends the episode still not knowing some of the level's
    walls: it did without the layout. (With what its rays show not learned, it walks into the walls and
    runs out of time.)"""
    env = gait_env
    controller = StrictSearchController(env)
    observation, _ = env.reset(seed=2, options={"level": 5, "difficulty": 0})
    controller.reset(2)
    for _ in range(env.max_steps // env.hold):
        observation, _, terminated, truncated, info = env.step(controller(observation))
        if terminated or truncated:
            break
    assert info["food_eaten"] == 1 and terminated and info["wall_hits"] == 0
    assert controller.hidden.any()


def test_the_thorough_search_waits_for_l2b_yellow_where_the_search_eats_the_green_at_once(gait_env):
    """L2b d0 seed 3: the green lies ahead in the rays' view, the yellow on its pillar above them. The
    searching reference eats the green at once, ending the episode with the yellow uneaten (below the
    pass mark); the thorough one searches on while the time allows, finds the yellow once it has
    sunk, eats it and then the green."""
    env, l2b = gait_env, {"level": 12, "difficulty": 0}
    plain = play(env, SearchController(env), 3, options=l2b)
    assert plain.info["food_eaten"] == 1 and plain.episode_return < PASS_RATIO * plain.info["max_reward"]
    thorough = play(env, ThoroughSearchController(env), 3, options=l2b)
    assert thorough.info["food_eaten"] == 2 and thorough.episode_return >= PASS_RATIO * thorough.info["max_reward"]


def test_the_thorough_search_holds_off_a_green_only_while_unseen_food_is_left_and_time_allows(gait_env):
    """L2b d0 seed 3, set down facing the green 8 units off: the green is known, the yellow (on its
    pillar) never seen. With time left a hair more than walking to the green takes (its straight
    line x HOLD_DETOUR at INTERCEPT_SPEED, + HOLD_MARGIN) it explores, keeping a berth round the
    green; a hair less, it goes for the green. Once a ray has shown it the yellow (wherever that is
    now) it goes for the green too, as the searching reference always does."""
    env = gait_env
    controller = ThoroughSearchController(env)
    env.reset(seed=3, options={"level": 12, "difficulty": 0})
    controller.reset(3)
    green = next(body for body, food in env.world.food.items() if food.kind == "food_green")
    yellow = next(body for body in env.world.food if body != green)
    x, y, _ = env.world.food[green].position
    controller(_place(env, x, y - 8.0, math.pi / 2))
    assert green in controller.memory and yellow not in controller.sighted
    head = env.body.head_pose()[0]
    walk = math.dist(head[:2], (x, y)) * HOLD_DETOUR / INTERCEPT_SPEED + HOLD_MARGIN
    limit, dt = env.level_spec.time_limit, env.control_dt
    for left, holds in ((walk + 0.05, True), (walk - 0.05, False)):
        env.steps = math.ceil((limit - left) / dt)  # just under ``left`` seconds to go
        target = controller._target(head)
        assert (target[2] != green) == holds, left
        if holds:
            assert target[2][0] == "explore" and any(math.dist(b[:2], (x, y)) < 0.5 for b in target[3])
    env.steps = 0
    controller.sighted.add(yellow)
    assert controller._target(head)[2] == green
