"""Heights in the solvability check (aaai.levels.validate): food on a ramp's slope (resting on it is
valid, a hair into it cuts in, a hair above it floats; an imported goal dropped over a ramp lands on
its slope), ramps walked over up to a height, food out of the head's reach above a height."""

import math

import numpy as np
import pytest

from aaai.levels.validate import check, ramp_clearance
from aaai.task.arena import parse_arena
from aaai.tools.animalai_arena import _settled, convert_arena

RAMP = "  - {kind: ramp, position: [0.0, 0.0, 5.0], size: [20.0, 10.0, 10.0], yaw: 0.0}\n"  # rises 10 over 20 along +x
# over x = 5 the slope is 7.5 high; a sphere of radius 2.5 touches it with its centre sqrt(1.25) x 2.5 above
RESTING = 7.5 + 2.5 * math.sqrt(1 + 0.5**2)


def problems(tmp_path, z: float) -> list[str]:
    path = tmp_path / "a.yaml"
    path.write_text(
        "arena_size: [100.0, 100.0]\ntime_limit: 100\nagent: {x: -40.0, y: -40.0, yaw: 0.0}\nobjects:\n"
        + RAMP
        + f"  - {{kind: food_green, shape: sphere, position: [5.0, 0.0, {z}], size: [5.0, 5.0, 5.0]}}\n"
    )
    return [p for p in check(parse_arena(path, 0)[0]) if "cannot be reached" not in p]  # a ramp 10 high: an obstacle


def test_food_resting_on_a_slope_is_valid_and_a_hair_either_side_is_not(tmp_path):
    assert problems(tmp_path, RESTING) == []
    assert any("cuts into ramp" in p for p in problems(tmp_path, RESTING - 0.1))
    assert any("not on solid ground" in p for p in problems(tmp_path, RESTING + 0.1))


def test_food_beside_a_ramp_meets_it_as_high_as_its_nearest_edge(tmp_path):
    path = tmp_path / "b.yaml"
    for x, cut in ((12.4, True), (12.6, False)):  # beside the high end (x = 10, 10 high), radius 2.5
        path.write_text(
            "arena_size: [100.0, 100.0]\ntime_limit: 100\nagent: {x: -40.0, y: -40.0, yaw: 0.0}\nobjects:\n"
            + RAMP
            + f"  - {{kind: food_green, shape: sphere, position: [{x}, 0.0, 2.5], size: [5.0, 5.0, 5.0]}}\n"
        )
        assert any("cuts into ramp" in p for p in check(parse_arena(path, 0)[0])) == cut


def test_an_imported_goal_dropped_over_a_ramp_lands_on_its_slope():
    arena = {
        "items": [
            # rotation 180: rises towards +z (Animal-AI's), from z 10 to z 14, 2 high
            {
                "name": "Ramp",
                "positions": [{"x": 20, "y": 0, "z": 12}],
                "sizes": [{"x": 4, "y": 2, "z": 4}],
                "rotations": [180],
            },
            {"name": "GoodGoal", "positions": [{"x": 20, "y": 5, "z": 13}], "sizes": [{"x": 1, "y": 1, "z": 1}]},
            {"name": "GoodGoal", "positions": [{"x": 30, "y": 5, "z": 13}], "sizes": [{"x": 1, "y": 1, "z": 1}]},
        ]
    }
    data, _ = convert_arena("t.yaml", 0, arena, 5.0, np.random.default_rng(0))
    ramp, over, beside = data["objects"]
    assert beside["position"][2] == pytest.approx(2.5)  # not over the ramp: on the floor
    # over z = 13 (our y = -35), three quarters up: 7.5 of 10 high; the piece lands touching the slope
    landed = _settled({**over, "position": [0.0, -35.0, 25.0]}, [], [ramp])
    assert landed["position"][2] == pytest.approx(7.5 + 2.5 * math.sqrt(1 + 0.5**2), abs=1e-3)
    from aaai.spec import ObjectSpec

    wedge = ObjectSpec("ramp", "box", tuple(ramp["position"]), tuple(ramp["size"]), ramp["yaw"])
    assert ramp_clearance(wedge, *landed["position"], 2.5) == pytest.approx(0.0, abs=1e-3)
    # and then rolls down it, off its foot (our y -50) and on to the arena's wall, where it rests on the floor
    assert data["extras"]["animalai"]["rolled"] == [{"from": [0.0, -35.0], "to": [0.0, -97.5]}]
    assert over["position"] == [0.0, -97.5, 2.5]


@pytest.mark.parametrize("height, walkable", [(0.95, True), (1.05, False)])
def test_a_low_ramp_is_walked_over_and_a_higher_one_is_an_obstacle(tmp_path, height, walkable):
    # a ramp across a corridor 30 wide; the food beyond it
    path = tmp_path / "c.yaml"
    path.write_text(
        "arena_size: [30.0, 100.0]\ntime_limit: 100\nagent: {x: 0.0, y: -40.0, yaw: 1.57}\nobjects:\n"
        f"  - {{kind: ramp, position: [0.0, 0.0, {height / 2}], size: [10.0, 30.0, {height}], yaw: 1.570796}}\n"
        "  - {kind: food_green, shape: sphere, position: [0.0, 40.0, 1.5], size: [3.0, 3.0, 3.0]}\n"
    )
    assert (check(parse_arena(path, 0)[0]) == []) == walkable


# the head's top rides at most 3.8 high while the body trots: a hair either side
@pytest.mark.parametrize("bottom, reachable", [(3.7, True), (3.9, False)])
def test_food_higher_than_the_head_reaches_is_out_of_reach(tmp_path, bottom, reachable):
    path = tmp_path / "d.yaml"
    path.write_text(
        "arena_size: [100.0, 100.0]\ntime_limit: 100\nagent: {x: -40.0, y: -40.0, yaw: 0.0}\nobjects:\n"
        f"  - {{kind: wall, position: [0.0, 0.0, {bottom / 2}], size: [0.4, 0.4, {bottom}]}}\n"  # a pole
        f"  - {{kind: food_green, shape: sphere, position: [0.0, 0.0, {bottom + 5}], size: [10.0, 10.0, 10.0]}}\n"
    )
    assert (check(parse_arena(path, 0)[0]) == []) == reachable


def test_food_on_a_sinking_pillar_is_in_reach_however_high(tmp_path):
    path = tmp_path / "e.yaml"
    text = (
        "arena_size: [100.0, 100.0]\ntime_limit: 100\nagent: {x: -40.0, y: -40.0, yaw: 0.0}\nobjects:\n"
        "  - {kind: wall, position: [0.0, 0.0, 5.0], size: [4.0, 4.0, 10.0]BEHAVIOUR}\n"
        "  - {kind: food_green, shape: sphere, position: [0.0, 0.0, 11.5], size: [3.0, 3.0, 3.0]}\n"
    )
    path.write_text(text.replace("BEHAVIOUR", ", behaviour: {type: sink, depth: 10.0, duration: 5.0}"))
    assert check(parse_arena(path, 0)[0]) == []
    path.write_text(text.replace("BEHAVIOUR", ""))
    assert any("cannot be reached" in p for p in check(parse_arena(path, 0)[0]))
