"""Dispensers and buttons (aaai.spec.dispensers): the food a dispenser gives appears at its time, the
food a button guards appears when the head touches the button; both kinds block like walls, are
seen on the rays and drawn by the viewer; the importer maps Animal-AI's spawners and buttons."""

import numpy as np
import pybullet as p
import pytest

from aaai.levels import validate
from aaai.sim.world import HIDDEN_Z
from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai.spec.kinds import KIND_INDEX, SOLID_KINDS, ray_channels
from aaai.task.arena import load_arena
from aaai.tools.animalai import import_animalai

FOOD = ObjectSpec("food_green", "sphere", (10.0, 0.0, 1.0), (2.0, 2.0, 2.0))


def spec_with(*objects) -> LevelSpec:
    return LevelSpec(0, "dispensers", 0, 0, AgentPose(-15.0, 0.0, 0.0), tuple(objects), arena_size=(50.0, 50.0))


def at(env, obj_kind):
    body = next(b for b, o in env.world.objects.items() if o.kind == obj_kind)
    return np.array(p.getBasePositionAndOrientation(body, physicsClientId=env.client)[0])


def test_dispensed_food_appears_at_its_time(make_env):
    food = ObjectSpec(**{**FOOD.__dict__, "behaviour": {"type": "release", "after": 0.5}})
    spawner = ObjectSpec("spawner", "box", (14.0, 0.0, 2.0), (3.0, 3.0, 4.0))
    env = make_env()
    env.reset(seed=0, options={"spec": spec_with(spawner, food), "check": False})
    assert at(env, "food_green")[2] == HIDDEN_Z
    steps = round(0.5 / env.control_dt)
    for _ in range(steps - 1):
        env.step(env.body.rest_action())
    assert at(env, "food_green")[2] == HIDDEN_Z  # a step short of its time
    env.step(env.body.rest_action())
    assert at(env, "food_green") == pytest.approx(FOOD.position)


def test_a_button_touched_by_the_head_gives_its_food(make_env):
    button = ObjectSpec("button", "cylinder", (-8.0, 8.0, 1.0), (2.0, 2.0, 2.0))
    food = ObjectSpec(**{**FOOD.__dict__, "behaviour": {"type": "press", "button": [-8.0, 8.0], "reach": 3.0}})
    env = make_env()
    env.reset(seed=0, options={"spec": spec_with(button, food), "check": False})
    for _ in range(3):  # the head far from it: nothing
        env.step(env.body.rest_action())
    assert at(env, "food_green")[2] == HIDDEN_Z
    for _ in range(2):  # the body moved so that its head is 2.5 from the button's centre, touching it
        p.resetBasePositionAndOrientation(env.body.id, (-8.0, 5.5, 1.5), (0, 0, 0, 1), physicsClientId=env.client)
        env.step(env.body.rest_action())
    assert at(env, "food_green") == pytest.approx(FOOD.position)


def test_spawners_and_buttons_block_the_body_and_are_seen_on_the_rays():
    assert {"spawner", "button"} <= set(SOLID_KINDS)
    classic, columns = ray_channels("classic")
    assert columns[KIND_INDEX["button"]] == classic.index("pillar")  # seen as a pillar
    mine, columns = ray_channels("all")
    assert "button" in mine and "spawner" in mine  # a channel each
    wall_across = ObjectSpec("spawner", "box", (0.0, 0.0, 2.0), (2.0, 50.0, 4.0))
    problems = validate.check(spec_with(wall_across, FOOD))
    assert any("cannot be reached" in problem for problem in problems)
    hidden = ObjectSpec(**{**FOOD.__dict__, "behaviour": {"type": "release"}})
    assert any("lacks after" in problem for problem in validate.check(spec_with(hidden)))


def test_the_viewer_draws_them():
    from aaai.tools.viewer import draw_top_down as top_down

    button = ObjectSpec("button", "cylinder", (-8.0, 8.0, 1.0), (2.0, 2.0, 2.0))
    spawner = ObjectSpec("spawner", "box", (14.0, 0.0, 2.0), (3.0, 3.0, 4.0))
    plain = top_down(spec_with(FOOD))
    image = top_down(spec_with(button, spawner, FOOD))
    assert image.shape == plain.shape and np.abs(image.astype(int) - plain.astype(int)).sum() > 0


SOURCE = """!ArenaConfig
arenas:
  0: !Arena
    t: 250
    items:
    - !Item
      name: Agent
      positions: [!Vector3 {x: 10, y: 0, z: 10}]
      rotations: [0]
    - !Item
      name: SpawnerDispenserTall
      positions: [!Vector3 {x: 20, y: 0, z: 30}]
      rotations: [180]
      spawnCounts: [2]
    - !Item
      name: SpawnerButton
      positions: [!Vector3 {x: 30, y: 0, z: 10}]
      rewardNames: [GoodGoal, BadGoal]
      rewardWeights: [0.2, 0.8]
      rewardSpawnPos: !Vector3 {x: 30, y: 0, z: 20}
"""


def test_the_importer_maps_dispensers_and_buttons(tmp_path):
    (tmp_path / "s.yaml").write_text(SOURCE)
    lines: list[str] = []
    (result,) = import_animalai(tmp_path / "s.yaml", tmp_path / "out", echo=lines.append)
    assert not result.problem, result.problem
    spec = load_arena(tmp_path / "out" / "s.yaml", require_food=False)
    by_kind: dict = {}
    for obj in spec.objects:
        by_kind.setdefault(obj.kind, []).append(obj)
    (spawner,) = by_kind["spawner"]
    assert spawner.position[:2] == (0.0, 50.0) and spawner.size[2] == pytest.approx(4.46 * 5)
    pieces = by_kind["multi_food"]
    step = 10 * 0.128 * 5  # an Animal-AI second: 10 steps
    assert [piece.behaviour["after"] for piece in pieces] == pytest.approx([10 * step, 11.5 * step])
    assert all(piece.position[1] < spawner.position[1] for piece in pieces)  # in front of it (facing -y)
    (button,) = by_kind["button"]
    (bad,) = by_kind["bad_food"]  # the likelier of the two
    assert bad.position[:2] == (50.0, 0.0) and bad.behaviour["type"] == "press"
    assert bad.behaviour["button"] == [50.0, -50.0] == list(button.position[:2])
