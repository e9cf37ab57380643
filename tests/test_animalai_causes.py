"""The import report's causes (aaai.tools.animalai_causes): why a piece of food is out of reach for
our body, tried one change at a time, and which way an imported ramp rises."""

import math

import numpy as np
import pytest

from aaai.levels.validate import check
from aaai.task.arena import parse_arena
from aaai.tools.animalai_arena import convert_arena
from aaai.tools.animalai_causes import problem_cause, unreachable_cause

HEAD = """description: a test
arena_size: [200.0, 200.0]
time_limit: 100
agent: {x: -80.0, y: -80.0, yaw: 0.0}
"""


def spec(tmp_path, objects: str, extras: str = ""):
    path = tmp_path / "a.yaml"
    path.write_text(HEAD + extras + "objects:\n" + objects)
    return parse_arena(path, 0)[0]


FOOD = "  - {{kind: food_green, shape: sphere, position: [{x}, {y}, {z}], size: [5.0, 5.0, 5.0]}}\n"


def pen(gap: float) -> str:
    """Four walls round (50, 50), touching at the corners, a gap of ``gap`` units in the south one."""
    side = 21 - gap / 2
    walls = [
        (50, 70, 42, 2),
        (30, 50, 2, 38),
        (70, 50, 2, 38),
        (29 + side / 2, 30, side, 2),
        (71 - side / 2, 30, side, 2),
    ]
    return "".join(f"  - {{kind: wall, position: [{x}, {y}, 5.0], size: [{w}, {d}, 10.0]}}\n" for x, y, w, d in walls)


def cause(tmp_path, objects: str, extras: str = "") -> str:
    level = spec(tmp_path, objects, extras)
    return unreachable_cause(level, level.foods[0])


def test_a_passage_narrower_than_our_body_but_not_animal_ais_is_named(tmp_path):
    # our footprint is 10 across, Animal-AI's agent 5 at scale 5: a grid cell either side of each
    assert not check(spec(tmp_path, pen(11) + FOOD.format(x=50, y=50, z=2.5)))
    assert cause(tmp_path, pen(9) + FOOD.format(x=50, y=50, z=2.5)) == "passage narrower than the body"
    assert cause(tmp_path, pen(6) + FOOD.format(x=50, y=50, z=2.5)) == "passage narrower than the body"
    assert cause(tmp_path, pen(4.5) + FOOD.format(x=50, y=50, z=2.5)) == "walled off"


def test_death_zones_and_pushable_blocks_are_named(tmp_path):
    zone = "  - {kind: death_zone, position: [50, 30, 0.01], size: [30.0, 8.0, 0.02]}\n"
    assert cause(tmp_path, pen(20) + zone + FOOD.format(x=50, y=50, z=2.5)) == "behind a death zone"
    inside = "  - {kind: death_zone, position: [50, 50, 0.01], size: [10.0, 10.0, 0.02]}\n"
    assert cause(tmp_path, pen(20) + inside + FOOD.format(x=50, y=50, z=2.5)) == "food in a death zone"
    ramp = "  - {kind: ramp, position: [50, 30, 2.5], size: [8.0, 22.0, 5.0], yaw: 1.570796}\n"
    assert cause(tmp_path, pen(20) + ramp + FOOD.format(x=50, y=50, z=2.5)) == "over a ramp the body does not climb"
    block = "  - {kind: plank, position: [50, 30, 5.0], size: [22.0, 2.0, 10.0], mass: 2.0}\n"
    assert cause(tmp_path, pen(20) + block + FOOD.format(x=50, y=50, z=2.5)) == "behind a pushable block"


def test_food_on_a_platform_is_named_with_or_without_a_ramp_up(tmp_path):
    platform = "  - {kind: wall, position: [50, 50, 7.5], size: [20.0, 20.0, 15.0]}\n" + FOOD.format(x=50, y=50, z=17.5)
    assert cause(tmp_path, platform) == "food on top of a solid"
    up = "  - {kind: ramp, position: [50, 30, 7.5], size: [20.0, 20.0, 15.0], yaw: 1.570796}\n"  # high end at y 40
    assert cause(tmp_path, platform + up) == "food on a platform up a ramp"
    down = "  - {kind: ramp, position: [50, 30, 7.5], size: [20.0, 20.0, 15.0], yaw: -1.570796}\n"  # faces away
    assert cause(tmp_path, platform + down) == "food on top of a solid"
    low = "  - {kind: ramp, position: [50, 30, 5.0], size: [20.0, 20.0, 10.0], yaw: 1.570796}\n"  # too low
    assert cause(tmp_path, platform + low) == "food on top of a solid"


def test_a_start_on_a_raised_floor_is_named(tmp_path):
    walled = pen(0) + FOOD.format(x=50, y=50, z=2.5)
    assert cause(tmp_path, walled) == "walled off"
    raised = cause(tmp_path, walled, "extras: {animalai: {start_height: 10.0}}\n")
    assert raised == "start on a raised floor, the food below it"


@pytest.mark.parametrize(
    "problem, expected",
    [
        (
            "a.yaml line 5, objects[2] (food_green): at (1.0, 2.0) cuts into objects[1] (ramp) at (0.0, 1.0)",
            "food cuts into a ramp",
        ),
        (
            "a.yaml line 5, objects[2] (plank): at (1.0, 2.0) overlaps objects[3] (plank) at (1.0, 2.0)",
            "movable blocks overlap",
        ),
        (
            "a.yaml line 5, objects[0] (wall): at (1.0, 2.0) overlaps objects[3] (plank) at (1.0, 2.0)",
            "plank and wall overlap",
        ),
        ("a.yaml line 2: the level has no food", "no food"),
    ],
)
def test_other_problems_are_named_by_the_kinds_they_involve(problem, expected):
    assert problem_cause(None, problem) == expected


def test_an_imported_ramp_rises_towards_its_own_minus_z():
    # Animal-AI's 03-17: a wall 3 high at (20, 20), a ramp 3 high south of it at rotation 180
    arena = {
        "items": [
            {
                "name": "Wall",
                "positions": [{"x": 20, "y": 0, "z": 20}],
                "sizes": [{"x": 5, "y": 3, "z": 5}],
                "rotations": [0],
            },
            {
                "name": "Ramp",
                "positions": [{"x": 20, "y": 0, "z": 15}],
                "sizes": [{"x": 5, "y": 3, "z": 5}],
                "rotations": [180],
            },
            {"name": "GoodGoal", "positions": [{"x": 20, "y": 4, "z": 20}], "sizes": [{"x": 1, "y": 1, "z": 1}]},
        ]
    }
    data, _ = convert_arena("03-17-01.yaml", 0, arena, 5.0, np.random.default_rng(0))
    ramp = next(o for o in data["objects"] if o["kind"] == "ramp")
    high = (
        ramp["position"][0] + math.cos(ramp["yaw"]) * ramp["size"][0] / 2,
        ramp["position"][1] + math.sin(ramp["yaw"]) * ramp["size"][0] / 2,
    )
    assert high == pytest.approx((0.0, -12.5), abs=1e-3)  # its high end meets the wall's south face


def test_imported_blocks_given_one_above_another_stack_as_they_fall():
    box = {"x": 1, "y": 1, "z": 1}
    arena = {
        "items": [  # listed top first: each lands on the one below, not on the floor
            {
                "name": "Cardbox1",
                "positions": [{"x": 20, "y": y, "z": 20} for y in (2.1, 1.05, 0)],
                "sizes": [box] * 3,
                "rotations": [0, 0, 0],
            },
            {"name": "GoodGoal", "positions": [{"x": 20, "y": 4, "z": 20}], "sizes": [box]},
        ]
    }
    data, _ = convert_arena("05-14-01.yaml", 0, arena, 5.0, np.random.default_rng(0))
    assert [o["position"][2] for o in data["objects"]] == [12.5, 7.5, 2.5, 17.5]


def _ramp_arena(goal_z: float, goal_y: float = 3.0, face: bool = False) -> dict:
    """Animal-AI's 02-21: a ramp 2 high on a wall 0.6 high over most of the arena, falling towards the
    agent's strip (z below 5); a goal given at (19, goal_z); with ``face``, a wall 3 high across the
    strip's far side at z 3 (its face toward the ramp at z 3.5)."""
    items = [
        {"name": "Wall", "positions": [{"x": 20, "y": 0, "z": 22.5}], "sizes": [{"x": 40, "y": 0.6, "z": 35}]},
        {
            "name": "Ramp",
            "positions": [{"x": 20, "y": 0.6, "z": 22.5}],
            "sizes": [{"x": 40, "y": 2, "z": 35}],
            "rotations": [180],
        },
        {"name": "GoodGoal", "positions": [{"x": 19, "y": goal_y, "z": goal_z}], "sizes": [{"x": 1, "y": 1, "z": 1}]},
    ]
    for item in items[:2]:
        item.setdefault("rotations", [0])
    if face:
        items.append(
            {
                "name": "Wall",
                "positions": [{"x": 20, "y": 0, "z": 3}],
                "sizes": [{"x": 40, "y": 3, "z": 1}],
                "rotations": [0],
            }
        )
    return {"items": items}


def test_an_imported_goal_on_a_ramps_slope_rolls_down_it_and_on_to_the_arenas_wall():
    data, _ = convert_arena("02-21-01.yaml", 0, _ramp_arena(9), 5.0, np.random.default_rng(0))
    goal = next(o for o in data["objects"] if o["kind"] == "food_green")
    # down the fall line (Animal-AI's -z, our -y), off the wall's edge at y -75, to the arena's wall
    assert goal["position"] == [-5.0, -97.5, 2.5]
    assert data["extras"]["animalai"]["rolled"] == [{"from": [-5.0, -55.0], "to": [-5.0, -97.5]}]


def test_a_rolling_goal_stops_against_a_face_and_one_on_a_flat_top_does_not_roll():
    data, _ = convert_arena("t.yaml", 0, _ramp_arena(9, face=True), 5.0, np.random.default_rng(0))
    goal = next(o for o in data["objects"] if o["kind"] == "food_green")
    assert goal["position"][1] == pytest.approx(-82.5 + 2.5, abs=0.25)  # the face at y -82.5, its radius 2.5
    assert goal["position"][2] == 2.5
    # the same goal on the wall's top without the ramp: it falls on to the top and stays there
    flat = _ramp_arena(9)
    del flat["items"][1]
    data, _ = convert_arena("t.yaml", 0, flat, 5.0, np.random.default_rng(0))
    goal = next(o for o in data["objects"] if o["kind"] == "food_green")
    assert goal["position"] == [-5.0, -55.0, 5.5]  # settled on the wall's top, 3 high
    assert "rolled" not in (data.get("extras") or {}).get("animalai", {})


def test_a_start_on_top_of_a_wall_is_recorded_and_one_merely_given_a_height_is_not():
    wall = {
        "name": "Wall",
        "positions": [{"x": 20, "y": 0, "z": 20}],
        "sizes": [{"x": 4, "y": 2, "z": 40}],
        "rotations": [0],
    }

    def start_height(x: float) -> float | None:
        agent = {"name": "Agent", "positions": [{"x": x, "y": 2, "z": 5}], "rotations": [0]}
        data, _ = convert_arena("t.yaml", 0, {"items": [wall, agent]}, 5.0, np.random.default_rng(0))
        return (data.get("extras") or {}).get("animalai", {}).get("start_height")

    assert start_height(21.9) == 10.0  # on the wall (x 18 to 22)
    assert start_height(22.1) is None  # beside it, in the air: Animal-AI lets it fall to the floor


@pytest.mark.parametrize(
    "width, beyond, mark, expected",
    [
        (31, "food_yellow", 11, "food that ends the episode in the way"),
        (120, "multi_food", 12, "the last multi_food ends the episode before the green"),
        (120, "food_yellow", 13, "a pass mark above all the arena's food pays"),
    ],
)
def test_a_pass_mark_out_of_reach_with_every_piece_in_reach_names_why(tmp_path, width, beyond, mark, expected):
    from aaai.task.arena import check_arena

    half = width / 2 + 0.5
    objects = (
        f"  - {{kind: wall, position: [{-half}, 0.0, 5.0], size: [1.0, 200.0, 10.0], yaw: 0.0}}\n"
        f"  - {{kind: wall, position: [{half}, 0.0, 5.0], size: [1.0, 200.0, 10.0], yaw: 0.0}}\n"
        "  - {kind: food_green, shape: sphere, position: [0.0, 0.0, 5.0], size: [10.0, 10.0, 10.0]}\n"
        f"  - {{kind: {beyond}, shape: sphere, position: [0.0, 50.0, 2.5], size: [5.0, 5.0, 5.0]}}\n"
    )
    path = tmp_path / "a.yaml"
    path.write_text(
        HEAD.replace("x: -80.0, y: -80.0", "x: 0.0, y: -90.0")
        + f"pass_mark: {mark}\nreach: pass_mark\n"
        + "objects:\n"
        + objects
    )
    found, _, source = parse_arena(path, 0)
    problems = check_arena(found, source)
    assert [problem_cause(found, p) for p in problems] == [expected]


def test_a_rolling_goal_stops_where_a_slope_rises_ahead_of_it():
    from aaai.tools.animalai_arena import _rolled, _settled

    # two ramps 5 high over 20 meeting at x 0 in a V: one rises along +x, the other along -x
    up = {"kind": "ramp", "position": [10.0, 0.0, 2.5], "size": [20.0, 40.0, 5.0], "yaw": 0.0}
    down = {"kind": "ramp", "position": [-10.0, 0.0, 2.5], "size": [20.0, 40.0, 5.0], "yaw": math.pi}
    goal = {"kind": "food_green", "shape": "sphere", "position": [10.0, 0.0, 30.0], "size": [5.0, 5.0, 5.0]}
    resting = _settled(goal, [], [up, down])  # on the slope of the first, 2.5 up it
    rolled = _rolled(resting, [], [up, down], 100.0)
    # down to the V's foot, where the slope ahead rises (within its radius of the foot), not on up the other side
    assert 0.0 <= rolled["position"][0] <= 2.5 and rolled["position"][1] == 0.0
