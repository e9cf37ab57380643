"""Bouncing food: the path the validator and the reference work out is the one the world moves it
along; a piece that starts in a death zone is fair exactly when its path leaves the zone within the
time limit; the reference meets a piece that only crosses the open strip between two zones."""

import dataclasses
import math

import numpy as np
from conftest import open_arena

from aaai.levels import validate
from aaai.sim.geometry import Bounds
from aaai.spec import ObjectSpec
from aaai.spec.behaviours import PATH_STEP, Bounce
from aaai.task.reference import ReferenceController


def bouncing(x: float, y: float, heading: float, speed: float = 3.0) -> ObjectSpec:
    return ObjectSpec(
        "food_green",
        "sphere",
        (x, y, 1.5),
        (3.0, 3.0, 3.0),
        behaviour={"type": "bounce", "speed": speed, "heading": heading},
    )


def zone(x: float, width: float) -> ObjectSpec:
    """A death zone across the whole 50-wide arena, ``width`` wide, its middle at ``x``."""
    return ObjectSpec("death_zone", "box", (x, 0.0, 0.01), (width, 50.0, 0.02))


def test_the_world_moves_a_bouncing_piece_along_the_path_worked_out_without_physics(make_env):
    block = ObjectSpec("wall", "box", (-12.0, 6.0, 1.5), (4.0, 10.0, 3.0))
    spec = open_arena(block, bouncing(10.0, 0.0, math.radians(160)), agent=(0.0, -18.0, 0.0))
    env = make_env(action_mode="gait")
    env.reset(seed=0, options={"spec": spec})
    assert env.unwrapped.control_dt == PATH_STEP
    moved = []
    for _ in range(200):  # 20 s in gait decisions of 0.1 s: off the block, the arena's walls, and back
        env.step(np.zeros(3, np.float32))
        moved.append(env.unwrapped.world.food_positions()[0])
    spec = env.unwrapped.level_spec
    path = Bounce.path(spec.foods[0], Bounds(spec).blocked, 20.0, every=0.1)
    np.testing.assert_allclose(np.array(moved), np.array(path), atol=1e-9)
    headings = [(np.sign(b[0] - a[0]), np.sign(b[1] - a[1])) for a, b in zip(path, path[1:])]
    assert sum(a != b for a, b in zip(headings, headings[1:])) >= 2  # reflected off the block, then a wall


def test_food_starting_in_a_death_zone_is_fair_when_its_path_leaves_the_zone_in_time():
    # the zone covers x 5..25; the open floor is x -25..5. Heading west the piece leaves the zone at
    # x = 5 - 1.5 after 10.5 / 3 = 3.5 s, and the body reaches it once it is a few units further.
    west = open_arena(zone(15.0, 20.0), bouncing(15.0, 0.0, math.pi), agent=(-15.0, 0.0, 0.0), time_limit=60.0)
    assert validate.check(west) == []
    short = dataclasses.replace(west, time_limit=2.0)  # still in the zone when the time is up
    assert any("cannot be reached" in problem for problem in validate.check(short))
    # heading north it goes up and down inside the zone for ever
    north = dataclasses.replace(west, objects=(*west.objects[:-1], bouncing(15.0, 0.0, math.pi / 2)))
    assert any("cannot be reached" in problem for problem in validate.check(north))


def test_a_first_reachable_place_between_the_bounds_of_the_time_limit():
    spec = open_arena(zone(15.0, 20.0), bouncing(15.0, 0.0, math.pi), agent=(-15.0, 0.0, 0.0), time_limit=60.0)
    food = spec.foods[0]
    region, clear = validate.reachable_region(spec)
    assert clear
    places = Bounce.path(food, Bounds(spec).blocked, 60.0)
    first = next(i for i, place in enumerate(places) if validate._reachable_at(spec, region, food, place))
    seconds = (first + 1) * 0.5  # places are kept every 0.5 s
    just_short = dataclasses.replace(spec, time_limit=seconds - 0.25)
    just_enough = dataclasses.replace(spec, time_limit=seconds + 0.25)
    assert not validate.food_reachable(just_short, region, just_short.foods[0])
    assert validate.food_reachable(just_enough, region, just_enough.foods[0])


def test_the_reference_meets_a_piece_that_only_crosses_the_strip_between_two_death_zones(make_env):
    # death zones x -25..-9 and 9..25; the piece starts in the east one heading north-west, crosses the
    # strip, bounces round the west one and crosses again: never still, never long where it can be eaten
    food = bouncing(17.0, -17.0, math.radians(135))
    spec = open_arena(zone(-17.0, 16.0), zone(17.0, 16.0), food, agent=(0.0, -17.0, math.pi / 2), time_limit=120.0)
    assert validate.check(spec) == []
    env = make_env(action_mode="gait")
    env.reset(seed=0, options={"spec": spec})
    controller = ReferenceController(env)
    controller.reset(0)
    observation = None
    for _ in range(1200):
        observation, reward, terminated, truncated, info = env.step(controller(observation))
        if terminated or truncated:
            break
    assert info["food_eaten"] == 1 and not info.get("fell"), info
