"""``on_overlap: redraw`` in arena files: an object placed as Animal-AI's ArenaBuilder places an item
(drawn again where it overlaps one before it, left out where it cannot be placed), and the importer
marking Animal-AI's random places with it."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from aaai.config import ConfigError
from aaai.levels import validate
from aaai.sim.geometry import TOLERANCE
from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai.task.arena import REDRAW_ATTEMPTS, parse_arena

# a wall over most of the floor, and food drawn anywhere over it
ARENA = """\
arena_size: [50, 50]
agent: {{x: -19, y: -19, yaw: 0}}
objects:
  - {{kind: wall, position: [0, 0, 1], size: [24, 24, 2]}}
  - {{kind: food_green, position: [{{uniform: [-16, 16]}}, {{uniform: [-16, 16]}}, 0.5], size: [1, 1, 1]{extra}}}
"""


def write(tmp_path: Path, text: str, name: str = "overlap.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_random_place_over_a_wall_is_drawn_again_until_it_is_clear(tmp_path):
    plain = write(tmp_path, ARENA.format(extra=""), "plain.yaml")
    redrawn = write(tmp_path, ARENA.format(extra=", on_overlap: redraw"), "redrawn.yaml")
    cut = 0
    for seed in range(20):
        spec = parse_arena(plain, seed)[0]
        cut += any("cuts into wall" in p for p in validate.food_problems(spec, spec.foods[0]))
        spec = parse_arena(redrawn, seed)[0]
        food = spec.foods[0]
        assert not any("cuts into" in p for p in validate.food_problems(spec, food))
        assert max(abs(food.position[0]), abs(food.position[1])) >= 12.5 - 1e-3  # beside the wall, not in it
        assert "left_out" not in spec.extras
    assert cut >= 10  # without the key, most draws land in the wall


def test_a_file_whose_objects_never_overlap_gives_the_same_spec_with_the_key(tmp_path):
    """The redraws come after every other draw: where none is needed, the spec is the one the file
    gave without the key (the same file name: the same draws)."""
    text = ARENA.replace("size: [24, 24, 2]", "size: [2, 2, 2]").replace("[-16, 16]", "[4, 16]")
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    plain = write(tmp_path / "a", text.format(extra=""), "same.yaml")
    marked = write(tmp_path / "b", text.format(extra=", on_overlap: redraw"), "same.yaml")
    for seed in range(5):
        assert parse_arena(plain, seed)[0] == parse_arena(marked, seed)[0]


def test_an_object_that_cannot_be_placed_is_left_out_and_recorded(tmp_path):
    path = write(
        tmp_path,
        """\
arena_size: [40, 40]
agent: {x: -15, y: -15, yaw: 0}
objects:
  - {kind: food_green, position: [10, 10, 0.5], size: [1, 1, 1]}
  - {kind: food_yellow, position: [10, 10, 0.5], size: [1, 1, 1], on_overlap: redraw}
  - {kind: wall, position: [0, 0, 1], size: [40, 24, 2]}
  - {kind: food_yellow, position: [0, {uniform: [-4, 4]}, 0.5], size: [1, 1, 1], on_overlap: redraw}
  - {kind: food_yellow, position: [-10, -10, 0.5], size: [1, 1, 1]}
""",
    )
    spec = parse_arena(path, 0)[0]
    assert spec.extras["left_out"] == [1, 3]  # a fixed place at once; a random one after every draw failed
    assert [o.position for o in spec.objects if o.is_food] == [(10, 10, 0.5), (-10, -10, 0.5)]
    assert spec.max_food_reward == pytest.approx(spec.objects[0].food_value + spec.objects[-1].food_value)
    assert REDRAW_ATTEMPTS == 20  # Animal-AI's ArenaBuilder's draws for an item


@pytest.mark.parametrize("gap, overlaps", [(-TOLERANCE + 1e-4, False), (-TOLERANCE - 1e-4, True)])
def test_food_a_hair_either_side_of_a_walls_face(gap, overlaps):
    """Food of radius 0.5 whose surface is ``gap`` from a wall's face: within the validator's
    tolerance it touches the face, beyond it cuts into it."""
    wall = ObjectSpec("wall", "box", (0.0, 0.0, 1.0), (4.0, 4.0, 2.0))
    food = ObjectSpec("food_green", "sphere", (2.5 + gap, 0.0, 0.5), (1.0, 1.0, 1.0))
    spec = LevelSpec(0, "food_contact", 0, 0, AgentPose(-15, -15, 0), (wall, food), arena_size=(40.0, 40.0))
    assert validate.overlaps_earlier(spec, 1) is overlaps
    assert validate.overlaps_earlier(spec, 0) is False  # nothing before the wall
    behind = LevelSpec(0, "food_contact", 0, 0, AgentPose(-15, -15, 0), (food, wall), arena_size=(40.0, 40.0))
    assert validate.overlaps_earlier(behind, 1) is overlaps  # a wall placed onto food overlaps it the same


def test_a_wrong_on_overlap_is_refused_naming_the_key_and_the_choices(tmp_path):
    path = write(tmp_path, ARENA.format(extra=", on_overlap: sometimes"))
    with pytest.raises(ConfigError, match=r"on_overlap.*'sometimes'.*refuse, redraw"):
        parse_arena(path, 0)


def test_the_importer_marks_animal_ais_random_places_and_no_fixed_one(tmp_path):
    from aaai.tools.animalai_arena import convert_arena

    source = yaml.safe_load(
        """
items:
- name: Wall
  positions: [{x: 20, y: 0, z: 20}]
  sizes: [{x: 10, y: 2, z: 10}]
- name: GoodGoal
  positions: [{x: -1, y: 0, z: -1}, {x: 5, y: 0, z: 5}]
  sizes: [{x: 1, y: 1, z: 1}, {x: 1, y: 1, z: 1}]
"""
    )
    arena, _ = convert_arena("test.yaml", 0, source, 5.0, np.random.default_rng(0))
    marks = {obj["kind"]: [] for obj in arena["objects"]}
    for obj in arena["objects"]:
        marks[obj["kind"]].append(obj.get("on_overlap"))
    assert marks["wall"] == [None]
    assert sorted(marks["food_green"], key=str) == [None, "redraw"]
