"""The level viewer: top-down pictures from a spec or a running world, and `aaai show`."""

import math
from dataclasses import replace

import cv2
import numpy as np
import pybullet as p
import pytest
from click.testing import CliRunner
from conftest import open_arena, sphere

from aaai.levels import generate
from aaai.levels.common import arena_walls
from aaai.spec import AgentPose, LevelSpec, ObjectSpec
from aaai.spec.kinds import COLOURS
from aaai.tools.viewer import (
    HEAD_COLOUR,
    HEADING_COLOUR,
    LEG_COLOUR,
    compose,
    draw_snapshot,
    draw_top_down,
    draw_world,
    mapping_for,
    rgb,
)
from aaai_cli.main import cli


def colour_at(image, mapping, x, y):
    col, row = mapping.to_px(x, y)
    return tuple(int(v) for v in image[row, col])


def run_show(*args):
    result = CliRunner().invoke(cli, ["show", *map(str, args)])
    return result


def count_frames(path) -> int:
    capture = cv2.VideoCapture(str(path))
    frames = 0
    while capture.read()[0]:
        frames += 1
    capture.release()
    return frames


def test_png_written_with_expected_size(tmp_path):
    out = tmp_path / "l0.png"
    result = run_show("L0", "--difficulty", 5, "--seed", 1, "-o", out)
    assert result.exit_code == 0, result.output
    image = cv2.imread(str(out))
    spec = generate(0, 5, 1)
    expected = compose(draw_top_down(spec), np.zeros((128, 128, 3), np.uint8))
    assert image.shape == expected.shape
    m = mapping_for(spec)
    assert image.shape[0] == m.height + 24 and image.shape[1] == m.width + 6 + m.height
    assert sorted(f.name for f in tmp_path.iterdir()) == ["l0.png"]  # no temporary left behind


def test_default_output_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = run_show("food_contact", "-d", 2, "-s", 3)
    assert result.exit_code == 0, result.output
    assert (tmp_path / "L0_d2_s3.png").is_file()


def test_food_and_agent_where_the_spec_puts_them():
    spec = generate(0, 5, 1)
    image = draw_top_down(spec)
    m = mapping_for(spec)
    food = spec.foods[0]
    assert colour_at(image, m, *food.position[:2]) == rgb(food.rgba)
    agent = spec.agent
    assert colour_at(image, m, agent.x, agent.y) == HEAD_COLOUR
    # a leg along a diagonal, and the heading arrow straight ahead beyond the head
    leg = agent.yaw + math.radians(135)
    assert colour_at(image, m, agent.x + 3.5 * math.cos(leg), agent.y + 3.5 * math.sin(leg)) == LEG_COLOUR
    assert colour_at(image, m, agent.x + 5 * math.cos(agent.yaw), agent.y + 5 * math.sin(agent.yaw)) == HEADING_COLOUR


def test_hole_tile_drawn_dark_and_other_tiles_floor():
    spec = open_arena(agent=(-15.0, -15.0, 0.0), tiles=(5, 5), holes=((3, 3),))
    image = draw_top_down(spec)
    m = mapping_for(spec)
    hole = colour_at(image, m, 10.0, 10.0)  # tile (3, 3) spans x, y in [5, 15]
    floor = colour_at(image, m, -10.0, 10.0)
    assert floor == rgb(COLOURS["floor"])
    assert sum(hole) < 0.4 * sum(floor)  # dark
    assert hole[0] > 2 * hole[1] and hole[0] > 2 * hole[2]  # the deadly floor's red shows through


def test_shapes_other_arenas_and_heightfield():
    objects = tuple(arena_walls((90.0, 45.0), 4.0)) + (
        ObjectSpec("transparent_wall", "box", (10.0, 5.0, 2.0), (12.0, 1.0, 4.0), yaw=0.5),
        ObjectSpec("pillar", "cylinder", (30.0, 10.0, 3.0), (4.0, 4.0, 6.0)),
        ObjectSpec("wall", "box", (-20.0, 0.0, 2.0), (2.0, 12.0, 4.0), yaw=math.pi / 2),
    )
    spec = LevelSpec(
        level=8,
        name="wide",
        difficulty=0,
        seed=0,
        agent=AgentPose(-30.0, -10.0, 0.0),
        objects=objects,
        arena_size=(90.0, 45.0),
    )
    image = draw_top_down(spec, size_px=600)
    m = mapping_for(spec, 600)
    assert image.shape == (m.height, m.width, 3) and m.width == 600 and m.width > m.height
    assert colour_at(image, m, 30.0, 10.0) == rgb(COLOURS["pillar"])
    assert colour_at(image, m, -25.0, 0.0) == rgb(COLOURS["wall"])  # the box turned by its yaw
    assert colour_at(image, m, -20.0, 5.0) == rgb(COLOURS["floor"])
    see_through = colour_at(image, m, 10.0, 5.0)
    assert see_through != rgb(COLOURS["floor"]) and see_through[2] > see_through[0]  # light blue tint

    rows = [[float(j)] * 8 for j in range(4)]  # rising to the north
    terrain = draw_top_down(replace(spec, heightfield=tuple(map(tuple, rows))), size_px=600)
    south, north = colour_at(terrain, m, -40.0, -20.0), colour_at(terrain, m, -40.0, 20.0)
    assert south[0] == south[1] == south[2] and north[0] == north[1] == north[2]
    assert north[0] > south[0] + 80


def test_door_not_yet_standing_is_only_outlined():
    door = ObjectSpec(
        "wall",
        "box",
        (0.0, 10.0, 2.0),
        (10.0, 2.0, 4.0),
        behaviour={"type": "door", "direction": [0.0, 1.0], "distance": 5.0},
    )
    spec = open_arena(door, agent=(0.0, -15.0, 0.0))
    m = mapping_for(spec)
    assert colour_at(draw_top_down(spec), m, 0.0, 10.0) == rgb(COLOURS["floor"])
    standing = draw_top_down(spec, objects=list(spec.objects))  # as a live world once it has risen
    assert colour_at(standing, m, 0.0, 10.0) == rgb(COLOURS["wall"])
    sunk = replace(door, position=(0.0, 10.0, -3.0))
    below = draw_top_down(spec, objects=[sunk if obj is door else obj for obj in spec.objects])  # in place, any order
    assert colour_at(below, m, 0.0, 10.0) == rgb(COLOURS["floor"])


def test_draw_world_follows_moving_food(make_env):
    walker = sphere("food_yellow", 5.0, 5.0, 2.0, behaviour={"type": "random_walk", "speed": 4.0})
    env = make_env(camera=False)
    env.reset(seed=0, options={"spec": open_arena(walker, agent=(-15.0, -15.0, 0.0))})
    body = next(iter(env.world.food))
    action = np.zeros(env.action_space.shape, np.float32)
    for _ in range(60):
        env.step(action)
    (x, y, _), _ = p.getBasePositionAndOrientation(body, physicsClientId=env.client)
    assert math.hypot(x - 5.0, y - 5.0) > 0.5
    image = draw_world(env)
    m = mapping_for(env.level_spec)
    assert colour_at(image, m, x, y) == rgb(COLOURS["food_yellow"])
    head, _ = env.body.head_pose()
    assert colour_at(image, m, head[0], head[1]) == HEAD_COLOUR


def test_video_has_one_frame_per_step_at_50_fps(tmp_path):
    out = tmp_path / "run.mp4"
    result = run_show("L1", "-d", 3, "-s", 2, "--video", out, "--steps", 30, "--fps", 50)
    assert result.exit_code == 0, result.output
    assert count_frames(out) == 30
    assert sorted(f.name for f in tmp_path.iterdir()) == ["run.mp4"]  # no PNG unless -o is given


def test_gait_video_to_avi_a_frame_every_second_step(tmp_path):
    out = tmp_path / "gait.avi"
    result = run_show("0", "--video", out, "--steps", 20, "--policy", "gait", "-o", tmp_path / "also.png")
    assert result.exit_code == 0, result.output
    assert count_frames(out) == 10
    assert (tmp_path / "also.png").is_file()


def test_reference_video_records_the_episode_to_its_end(tmp_path):
    out = tmp_path / "reference.mp4"
    result = run_show("L0", "-d", 0, "-s", 1, "--video", out, "--steps", 1000, "--fps", 50, "--policy", "reference")
    assert result.exit_code == 0, result.output
    assert "ate green food" in result.output  # the reference eats the food before 1000 steps
    assert 0 < count_frames(out) < 1000


@pytest.mark.parametrize(
    "args, words",
    [
        (["L0", "--video", "x.mp4", "--policy", "nobody"], ["'nobody'", "reference", "random"]),
        (["L0", "-o", "x.jpg"], ["'x.jpg'", ".png"]),
        (["L0", "--video", "x.gif"], ["'x.gif'", ".mp4 or .avi", "GIF"]),
        (["L0", "--video", "x.mov"], ["'x.mov'", ".mp4 or .avi"]),
        (["L99"], ["'L99'", "does not exist", "allowed"]),
        (["L0", "-d", "11"], ["'--difficulty'", "11", "0<=x<=10"]),
        (["L0", "-o", "no/such/folder/x.png"], ["does not exist"]),
    ],
)
def test_bad_input_fails_with_one_clear_message(tmp_path, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    result = run_show(*args)
    assert result.exit_code == 2
    for word in words:
        assert word in result.output
    assert list(tmp_path.iterdir()) == []


def test_snapshot_is_plain_data_by_spec_index_and_drawn_as_the_world(make_env):
    door = ObjectSpec(
        "wall",
        "box",
        (0.0, 10.0, 2.0),
        (10.0, 2.0, 4.0),
        behaviour={"type": "door", "direction": [0.0, 1.0], "distance": 5.0},
    )
    pieces = (sphere("food_yellow", 10.0, -10.0, 2.0), sphere("food_yellow", -10.0, -10.0, 2.0))
    env = make_env(camera=False)
    env.reset(seed=0, options={"spec": open_arena(door, *pieces, agent=(0.0, -15.0, 0.0))})
    spec = env.level_spec  # found by value, not by where the walls happen to stand in the list
    first, second, door_at = (spec.objects.index(obj) for obj in (*pieces, door))
    eaten = next(body for body, obj in env.world.food.items() if obj == pieces[0])
    env.world.remove(eaten)  # the first piece, as if eaten
    snapshot = env.snapshot()
    assert snapshot.objects[first] is None
    assert (snapshot.objects[second].x, snapshot.objects[second].y) == pytest.approx((-10.0, -10.0))
    assert snapshot.objects[door_at].z < 0 and snapshot.closed_doors == frozenset()  # the door waits below
    assert len(snapshot.legs) == 4 and snapshot.time == 0.0
    points = [point for leg in snapshot.legs for point in (leg.hip, leg.knee, leg.foot)]
    values = [snapshot.time, *vars(snapshot.head).values(), *(v for point in points for v in point)]
    assert all(type(v) is float for v in values)  # no numpy or PyBullet types: plain data
    image = draw_snapshot(spec, snapshot)
    assert np.array_equal(image, draw_world(env))
    m = mapping_for(spec)
    assert colour_at(image, m, 10.0, -10.0) == rgb(COLOURS["floor"])  # the eaten piece is gone
    assert colour_at(image, m, -10.0, -10.0) == rgb(COLOURS["food_yellow"])
    assert colour_at(image, m, 0.0, 10.0) == rgb(COLOURS["floor"])  # the door: an outline only
