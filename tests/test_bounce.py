"""Bouncing food: the path the validator and the reference work out is the one the world moves it
along; a piece that starts in a death zone is fair exactly when its path leaves the zone within the
time limit; the reference meets a piece that only crosses the open strip between two zones."""

import dataclasses
import math

import numpy as np
import pytest
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
    path = Bounce.path(spec.foods[0], Bounds(spec), 20.0, every=0.1)
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
    places = Bounce.path(food, Bounds(spec), 60.0)
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


def platform(*extra: ObjectSpec, kerb: float = 0.0, size: float = 3.0) -> list[ObjectSpec]:
    """A platform 2 high over y 5..25 (higher than the body mounts), a bouncing piece ``size`` across
    on it heading east, and a wall turned 45 degrees at its east end that sends the piece south, off
    the edge; with ``kerb`` > 0 a kerb that high along the edge."""
    piece = bouncing(-10.0, 15.0, 0.0)
    objects = [
        ObjectSpec("wall", "box", (0.0, 15.0, 1.0), (50.0, 20.0, 2.0)),
        ObjectSpec("wall", "box", (15.0, 15.0, 3.5), (12.0, 0.5, 3.0), yaw=-math.pi / 4),
        dataclasses.replace(piece, position=(-10.0, 15.0, 2.0 + size / 2), size=(size,) * 3),
        *extra,
    ]
    if kerb:
        objects.append(ObjectSpec("wall", "box", (0.0, 5.5, 2.0 + kerb / 2), (50.0, 1.0, kerb)))
    return objects


@pytest.mark.parametrize("size", [3.0, 10.0])  # the large one's centre is still over the edge as it falls below it
def test_a_bouncing_piece_is_turned_by_a_slanted_wall_and_falls_off_a_platform_as_the_world_moves_it(make_env, size):
    spec = open_arena(*platform(size=size), agent=(0.0, -18.0, 0.0), time_limit=60.0)
    env = make_env(action_mode="gait")
    env.reset(seed=0, options={"spec": spec})
    moved = []
    for _ in range(300):  # 30 s
        env.step(np.zeros(3, np.float32))
        moved.append(env.unwrapped.world.food_positions()[0])
    path = np.array(Bounce.path(env.unwrapped.level_spec.foods[0], Bounds(env.unwrapped.level_spec), 30.0, every=0.1))
    np.testing.assert_allclose(np.array(moved), path, atol=1e-9)
    turned = int(np.argmax(path[:, 1] < 14.0))  # east along the top, then south
    radius = size / 2
    assert np.all(np.diff(path[:turned, 0]) >= 0) and path[turned, 0] > 5.0
    assert np.allclose(path[:turned, 2], 2 + radius)
    assert abs(path[turned, 0] - path[-1, 0]) < 1e-6  # straight south from there on: reflected, not sent back
    landed = int(np.argmax(path[:, 2] < radius + 1e-9))
    assert landed > turned and path[landed, 1] < 5.0  # fell off the edge onto the floor ...
    # ... and stays on it, out of the platform: as near as its side (or, for the large one, its edge)
    nearest = math.sqrt(radius**2 - max(radius - 2.0, 0.0) ** 2)
    assert np.all(path[landed:, 2] == radius) and np.all(path[landed:, 1] < 5.0 - nearest + 0.1)
    assert path[landed:, 1].min() < -25.0 + radius + 0.5  # on to the arena's south wall, and back to the platform


def test_food_a_bouncing_piece_brings_down_is_fair_and_a_kerb_a_hair_higher_than_it_goes_over_keeps_it_up():
    from aaai.spec.behaviours import STEP_OVER

    def problems(**kerb):
        return validate.check(open_arena(*platform(**kerb), agent=(0.0, -18.0, 0.0), time_limit=60.0))

    assert problems() == []
    assert problems(kerb=STEP_OVER - 0.01) == []  # it goes over the kerb and off the edge
    assert any("cannot be reached" in problem for problem in problems(kerb=STEP_OVER + 0.01))
    # without the slanted wall it goes east and west along the top for ever, out of the body's reach
    spec = open_arena(*(o for i, o in enumerate(platform()) if i != 1), agent=(0.0, -18.0, 0.0), time_limit=60.0)
    assert any("cannot be reached" in problem for problem in validate.check(spec))


def test_a_piece_that_leaves_reach_in_its_first_second_is_fair_only_for_a_body_that_starts_near_it():
    # the zone covers x 5..25; the piece starts on the open floor at x 0 heading into it, and is back out
    # only after the time limit: it can be eaten in its first second, by a body that is there by then
    def spec(agent):
        return open_arena(zone(15.0, 20.0), bouncing(0.0, 0.0, 0.0), agent=agent, time_limit=10.0)

    assert validate.check(spec((-6.0, 0.0, 0.0))) == []
    far = spec((-18.0, 15.0, 0.0))
    assert any("cannot be reached" in problem for problem in validate.check(far))
    region, _ = validate.reachable_region(far)
    assert validate.food_reachable(far, region, far.foods[0], speed=None)  # the sphere, many times as fast
