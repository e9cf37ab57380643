"""A start on a dividing wall becomes a one-way ledge (aaai.tools.animalai_fit.place_ledge): the start
on it is clear, the body steps down from it to either side, and the floor does not lead back up."""

import dataclasses
import math

import numpy as np
import pytest

from aaai.levels import validate
from aaai.levels.common import arena_walls, sphere
from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai.tools.animalai_fit import LEDGE_HEIGHT, place_ledge

SIZE = 60.0


def ledge_arena(
    start=(0.0, 0.0), height=LEDGE_HEIGHT, food=((-20.0, 0.0), (20.0, 0.0)), ledge=True, yaw=math.pi / 2
) -> LevelSpec:
    """A wall across the arena along y with a ledge 12 across cut into it at the middle; food on each side."""
    half = 6.0
    wall_top = 5.0
    pieces = (
        ObjectSpec("wall", "box", (0.0, (SIZE / 2 + half) / 2, wall_top / 2), (4.0, SIZE / 2 - half, wall_top), 0.0),
        ObjectSpec("wall", "box", (0.0, -(SIZE / 2 + half) / 2, wall_top / 2), (4.0, SIZE / 2 - half, wall_top), 0.0),
        ObjectSpec("pillar", "box", (0.0, 0.0, height / 2), (2 * half, 2 * half, height), 0.0),
    )
    foods = tuple(sphere("food_yellow", x, y, 2.0) for x, y in food)
    extras = {"animalai": {"start_ledge": {"at": list(start), "height": height, "wall_top": wall_top}}} if ledge else {}
    return LevelSpec(
        level=0,
        name="ledge",
        difficulty=0,
        seed=0,
        agent=AgentPose(*start, yaw),  # by default facing along the wall, as the imports do
        objects=tuple(arena_walls((SIZE, SIZE), 4.0)) + pieces + foods,
        arena_size=(SIZE, SIZE),
        max_food_reward=sum(f.food_value for f in foods),
        extras=extras,
    )


def test_a_start_on_the_ledge_is_clear_and_reaches_the_floor_on_both_sides():
    spec = ledge_arena()
    assert validate.start_ledge(spec) is not None
    assert validate.check(spec) == []


def test_the_floor_does_not_lead_back_up_on_to_the_ledge():
    # from the floor on the left, the food on the right lies only across the ledge: out of reach
    spec = ledge_arena(start=(-20.0, 10.0), food=((20.0, 0.0),), ledge=False)
    assert validate.check(spec) == ["food_yellow at (20.0, 0.0) cannot be reached from the start"]
    # and food on the ledge is never reached from the floor next to it
    region, clear = validate.reachable_region(ledge_arena())
    assert clear and not region[validate.cell(spec, 0.0, 0.0, region.shape)]


@pytest.mark.parametrize(
    "start, clear",
    [((6.0 - validate.LEDGE_FOOTING, 0.0), True), ((6.0 - validate.LEDGE_FOOTING + 0.01, 0.0), False)],
)
def test_the_body_stands_on_the_ledge_up_to_a_hair_from_its_footing(start, clear):
    problems = validate.check(ledge_arena(start=start))
    assert (problems == []) is clear
    if not clear:
        assert "on a ledge is not clear" in problems[0]


@pytest.mark.parametrize("height", [validate.LEDGE_CLIMB, validate.LEDGE_DROP + 0.01])
def test_a_ledge_the_body_climbs_or_falls_from_is_not_clear(height):
    assert "on a ledge is not clear" in validate.check(ledge_arena(height=height))[0]


def test_the_importer_puts_a_start_on_a_dividing_wall_on_a_ledge_and_cuts_the_wall():
    wall = {"kind": "wall", "position": [0.0, 0.0, 2.5], "size": [5.0, 200.0, 5.0], "yaw": 0.0, "colour": [0, 0, 1, 1]}
    data = {"arena_size": [200.0, 200.0], "agent": {"x": 0.0, "y": -94.0, "yaw": math.pi / 2}, "objects": [wall]}
    assert place_ledge(data, 5.0) == "start on a ledge"
    kinds = [(o["kind"], o["position"], o["size"]) for o in data["objects"]]
    assert kinds == [
        ("wall", [0.0, 6.0, 2.5], [5.0, 188.0, 5.0]),  # the wall from the ledge's edge on
        ("pillar", [0.0, -94.0, LEDGE_HEIGHT / 2], [12.0, 12.0, LEDGE_HEIGHT]),
    ]
    assert data["extras"]["animalai"]["start_ledge"] == {"at": [0.0, -94.0], "height": LEDGE_HEIGHT, "wall_top": 5.0}
    assert data["agent"] == {"x": 0.0, "y": -94.0, "yaw": math.pi / 2}  # it stays, facing the same way


@pytest.fixture(scope="module")
def env():
    from aaai.env import AnimalAIEnv

    made = AnimalAIEnv()
    yield made
    made.close()


def _drive(env, spec, target, seconds):
    """The gait steered at ``target``; returns the head's highest z after the start, its last position and
    the lowest uprightness (z of the head's up axis)."""
    from aaai.tools.gait_tuning import follow

    env.reset(options={"spec": spec, "check": False})
    start_z = env.body.head_pose()[0][2]
    from aaai.sim.gait import SineGait

    result = follow(env, SineGait.for_env(env), spec, [target], seconds)
    head = env.body.head_pose()[0]
    return start_z, head, result["upright"]


@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_the_body_spawns_on_the_ledge_and_steps_down_upright_to_either_side(env, side):
    spec = ledge_arena(food=())
    start_z, head, upright = _drive(env, spec, (20.0 * side, 0.0), 8.0)
    assert start_z > LEDGE_HEIGHT + 1.0  # it stood on the ledge
    assert head[0] * side > 10.0 and head[2] < LEDGE_HEIGHT + 1.2 and upright > 0.6  # down, on its feet


def test_from_the_floor_the_body_does_not_climb_back_on_to_the_ledge(env):
    spec = ledge_arena(start=(-20.0, 0.0), food=(), ledge=False, yaw=0.0)  # straight at it (a step of 1 is mounted)
    _, head, _ = _drive(env, spec, (0.0, 0.0), 12.0)
    assert head[0] < -6.0 and head[2] < LEDGE_HEIGHT + 1.2


def test_the_spawn_height_is_the_ledges_top():
    from aaai.sim.world import World

    spec = ledge_arena()
    assert World.ground_height(type("W", (), {"spec": spec})(), 0.0, 0.0) == pytest.approx(LEDGE_HEIGHT)
    assert World.ground_height(type("W", (), {"spec": spec})(), 20.0, 0.0) == 0.0
    assert np.isfinite(LEDGE_HEIGHT)


LEDGE_FILE = """arena_size: [200, 200]
extras: {animalai: {start_ledge: {at: [0.0, -94.0], height: 1.5, wall_top: 5.0}}}
agent: {x: 0.0, y: -94.0, yaw: 1.570796}
objects:
  - {kind: wall, position: [0.0, 6.0, 2.5], size: [5.0, 188.0, 5.0]}
  - {kind: food_green, shape: sphere, position: [-50.0, 50.0, 2.5], size: [5.0, 5.0, 5.0]}
  - {kind: pillar, position: [0.0, -94.0, 0.75], size: [12.0, 12.0, 1.5]}
"""


def test_an_arena_file_with_a_start_on_a_ledge_loads_for_the_quadruped_and_not_for_the_sphere(tmp_path):
    from aaai.config import ConfigError
    from aaai.task.arena import load_arena

    path = tmp_path / "ledge.yaml"
    path.write_text(LEDGE_FILE)
    assert validate.start_ledge(load_arena(path)) is not None
    # the sphere (radius 2.5 here) rolls up a step lower than its radius: the ledge would not be one way
    with pytest.raises(ConfigError, match=r"line 3, agent: the agent's start \(0.0, -94.0\) on a ledge is not clear"):
        load_arena(path, body="sphere")


def test_a_ledge_widens_over_a_strip_of_wall_narrower_than_the_body():
    wall = {"kind": "wall", "position": [0.0, 0.0, 2.5], "size": [15.0, 200.0, 5.0], "yaw": 0.0}
    data = {"arena_size": [200.0, 200.0], "agent": {"x": 0.0, "y": -94.0, "yaw": 0.0}, "objects": [wall]}
    assert place_ledge(data, 5.0) == "start on a ledge"
    # the wall is 15 wide: cut to 12, strips 1.5 wide would stand either side of the ledge; it takes them
    assert [(o["kind"], o["size"]) for o in data["objects"]] == [
        ("wall", [15.0, 188.0, 5.0]),
        ("pillar", [15.0, 12.0, LEDGE_HEIGHT]),
    ]


def test_a_start_on_a_wide_raised_floor_is_named_and_not_put_on_a_ledge(tmp_path):
    from conftest import AAI_AGENT, AAI_GOAL

    from aaai.tools.animalai import import_animalai

    platform = (
        "    - !Item\n      name: Wall\n      positions: [!Vector3 {x: 20, y: 0, z: 20}]\n"
        "      sizes: [!Vector3 {x: 30, y: 2, z: 40}]\n      rotations: [0]\n"
    )
    agent = AAI_AGENT.format(x=20, z=20, r=0).replace("y: 0,", "y: 2,")
    text = "!ArenaConfig\narenas:\n  0: !Arena\n    t: 250\n    items:\n" + agent + platform
    text += AAI_GOAL.format(x=2, z=20) + AAI_GOAL.format(x=38, z=20)
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "raised.yaml").write_text(text)
    (result,) = import_animalai(tmp_path / "src", tmp_path / "out", echo=lambda line: None)
    assert result.unfair and result.unfair[0].startswith("start on a raised floor")
    assert "start_ledge" not in (tmp_path / "out" / "unfair" / "raised.yaml").read_text()


def test_a_bar_overhead_does_not_lift_the_spawn():
    from aaai.sim.world import World

    bar = ObjectSpec("wall", "box", (0.0, 0.0, 20.0), (40.0, 2.0, 1.0), 0.0)  # high above the start
    spec = ledge_arena(ledge=False)
    spec = LevelSpec(**{**spec.__dict__, "objects": (bar,)})
    assert World.ground_height(type("W", (), {"spec": spec})(), 0.0, 0.0) == 0.0


def test_a_ledge_cuts_walls_stacked_on_the_dividing_wall_and_leaves_a_bar_above_it():
    low = {"kind": "wall", "position": [0.0, -50.0, 1.25], "size": [10.0, 100.0, 2.5], "yaw": 0.0}
    stacked = {"kind": "wall", "position": [0.0, -87.5, 3.75], "size": [10.0, 25.0, 2.5], "yaw": 0.0}
    bar = {"kind": "wall", "position": [0.0, -90.0, 20.0], "size": [40.0, 1.0, 1.0], "yaw": 0.3}
    data = {"arena_size": [200.0, 200.0], "agent": {"x": 0.0, "y": -90.0, "yaw": 0.0}, "objects": [low, stacked, bar]}
    assert place_ledge(data, 5.0) == "start on a ledge"
    under = [o for o in data["objects"] if o["kind"] == "wall" and o["position"][2] < 5.0]
    # the strips left below (4 deep) and above the ledge (the stacked wall's, 9) are narrower than the body:
    # the ledge takes them, from the arena's edge to the stacked wall's end, and the low wall goes on from there
    assert [(o["position"][1], o["size"][1]) for o in under] == [(-37.5, 75.0)]
    assert data["objects"][-1]["size"] == [12.0, 25.0, LEDGE_HEIGHT] and bar in data["objects"]


def two_sided(folder, pass_mark: float):
    """LEDGE_FILE with a yellow on each side of the ledge (2.5 each) and the given pass mark."""
    sides = LEDGE_FILE.replace(
        "  - {kind: food_green, shape: sphere, position: [-50.0, 50.0, 2.5], size: [5.0, 5.0, 5.0]}\n",
        "  - {kind: food_yellow, shape: sphere, position: [-50.0, 50.0, 2.5], size: [5.0, 5.0, 5.0]}\n"
        "  - {kind: food_yellow, shape: sphere, position: [50.0, 50.0, 2.5], size: [5.0, 5.0, 5.0]}\n",
    )
    path = folder / "sides.yaml"
    path.write_text(sides + f"reach: pass_mark\npass_mark: {pass_mark:g}\n")
    return path


def test_from_a_ledge_the_pass_mark_counts_the_food_of_one_side(tmp_path):
    from aaai.task.arena import load_arena, reachable_return

    path = two_sided(tmp_path, pass_mark=1)
    spec = load_arena(path)  # each piece is worth 2.5, the step term takes at most 1
    assert validate.check(spec) == []
    assert reachable_return(spec) == pytest.approx(1.5)  # one side's piece, never both sides' (4)


def test_from_a_ledge_a_pass_mark_only_both_sides_give_is_a_problem_named_by_its_cause(tmp_path):
    from aaai.task.arena import check_arena, parse_arena
    from aaai.tools.animalai_causes import ONE_SIDE, problem_cause

    path = two_sided(tmp_path, pass_mark=3)
    spec, _, source = parse_arena(path)
    (problem,) = check_arena(spec, source)
    assert problem.endswith("gives at most 1.50, below the pass mark 3 (from a ledge, the food of one side)")
    assert problem_cause(spec, problem) == ONE_SIDE


@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_the_reference_plans_from_the_ledge_down_to_the_food(env, side):
    from aaai.task.reference import ReferenceController

    spec = ledge_arena(food=((20.0 * side, -10.0),))
    observation, _ = env.reset(options={"spec": spec})
    reference = ReferenceController(env)
    for _ in range(800):
        observation, _, terminated, truncated, info = env.step(reference(observation))
        if terminated or truncated:
            break
    assert info["food_eaten"] == 1 and reference.ledge is None  # down, and the ledge a solid in its map again


def test_from_a_ledge_the_reference_takes_the_side_whose_food_is_worth_most(env):
    from aaai.task.reference import ReferenceController

    spec = ledge_arena(food=((-20.0, -10.0), (20.0, -10.0), (20.0, 10.0)))  # one piece left, two right
    observation, _ = env.reset(options={"spec": spec})
    reference = ReferenceController(env)
    reference(observation)
    assert [food.position[:2] for food in reference.lures] == [(-20.0, -10.0)]  # the left one is never gone for


def test_a_start_over_stacked_boxes_spawns_on_the_top_one():
    from aaai.sim.world import World

    low = ObjectSpec("wall", "box", (0.0, 0.0, 1.0), (40.0, 40.0, 2.0), 0.0)
    stacked = ObjectSpec("wall", "box", (0.0, 0.0, 3.0), (30.0, 30.0, 2.0), 0.0)  # on the low one: 4 high
    bar = ObjectSpec("wall", "box", (0.0, 0.0, 20.0), (40.0, 2.0, 1.0), 0.0)  # overhead
    spec = LevelSpec(**{**ledge_arena(ledge=False).__dict__, "objects": (low, stacked, bar)})
    assert World.ground_height(type("W", (), {"spec": spec})(), 0.0, 0.0) == 4.0


def ledge_arena_with_slot(
    slot_y: float, time_limit: float = 120.0, ball_x: float = -10.0, greens: tuple = ((20.0, -20.0),)
) -> LevelSpec:
    """ledge_arena with a slot 4 wide in the dividing wall about y = ``slot_y`` (narrower than the body, wide
    enough for a ball); a yellow ball bouncing across it, starting at ``ball_x`` heading away from the
    slot (by default on the left), and greens (by default one on the right)."""
    spec = ledge_arena(food=())
    upper = [obj for obj in spec.objects if obj.kind == "wall" and obj.position[0] == 0.0 and obj.position[1] > 0]
    objects = [obj for obj in spec.objects if obj not in upper]
    for y0, y1 in ((6.0, slot_y - 2.0), (slot_y + 2.0, SIZE / 2)):
        objects.append(ObjectSpec("wall", "box", (0.0, (y0 + y1) / 2, 2.5), (4.0, y1 - y0, 5.0), 0.0))
    heading = math.pi if ball_x < 0 else 0.0
    ball = sphere("food_yellow", ball_x, slot_y, 2.0, behaviour={"type": "bounce", "speed": 2.0, "heading": heading})
    foods = (ball, *(sphere("food_green", x, y, 3.0) for x, y in greens))
    return dataclasses.replace(
        spec,
        objects=tuple(objects) + foods,
        max_food_reward=sum(food.food_value for food in foods),
        time_limit=time_limit,
    )


# y 12: the ball passes places on the left where the body could wait for it before any on the right;
# y 22: it runs too near the arena's wall for the body to wait anywhere on its path (it is chased).
@pytest.mark.parametrize("slot_y", [12.0, 22.0])
def test_from_a_ledge_the_reference_meets_a_bouncing_piece_on_the_side_it_chose(env, slot_y):
    """The ball's path crosses to both sides through the slot, the green is on the right: the right is
    worth more (the first of sides). The reference waits on the ledge and meets the ball on the right, then eats
    the green. Going down on the left for the ball, the body could not come back for the green."""
    from aaai.task.arena import sides
    from aaai.task.reference import ReferenceController

    spec = ledge_arena_with_slot(slot_y)
    side = sides(spec)[0][1]
    assert side[validate.cell(spec, 20.0, -20.0, side.shape)] and not side[validate.cell(spec, -20.0, 0.0, side.shape)]
    observation, _ = env.reset(options={"spec": spec})
    reference = ReferenceController(env)
    lowest_x = 0.0
    for _ in range(6000):  # 120 s, the time limit
        observation, _, terminated, truncated, info = env.step(reference(observation))
        lowest_x = min(lowest_x, float(env.body.head_pose()[0][0]))
        if terminated or truncated:
            break
    assert lowest_x > -6.0  # it never went down on the left (the ledge's edge is at x -6)
    assert terminated and info["food_eaten"] == 2  # the ball, then the green


def test_from_a_ledge_with_sides_worth_the_same_the_reference_goes_for_a_bouncing_piece_at_once(env):
    """A green on each side and the ball's path over both: neither side is worth more, so the reference
    does not wait on the ledge for the ball to come over one (it would stand there while the ball is on
    the right, the side it takes first of equals being the left): it goes down after it at once."""
    from aaai.task.arena import sides
    from aaai.task.reference import ReferenceController

    spec = ledge_arena_with_slot(22.0, ball_x=10.0, greens=((-20.0, -20.0), (20.0, -20.0)))
    (left_worth, left), (right_worth, _) = sides(spec)
    assert left_worth == right_worth and left[validate.cell(spec, -20.0, 0.0, left.shape)]
    observation, _ = env.reset(options={"spec": spec})
    reference = ReferenceController(env)
    for _ in range(500):  # 10 s
        observation, *_ = env.step(reference(observation))
    assert env.body.head_pose()[0][0] > 6.0  # off the ledge (its edge at x 6), on the right, after the ball
