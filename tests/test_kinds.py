"""The newer object kinds (aaai.spec.kinds): their rules in the rewards, the rays, the camera, the viewer,
validation and the reference controller; and the camera that agrees with the task."""

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import open_arena, sphere

from aaai.config import ConfigError
from aaai.env import AnimalAIEnv
from aaai.levels import validate
from aaai.spec import ObjectSpec
from aaai.spec.kinds import ALL_KINDS, COLOURS, HOT_ZONE_FACTOR, KINDS, REGISTRY, ZONE_THICKNESS, ray_channels
from aaai.task.arena import load_arena
from aaai.tools.viewer import draw_top_down, mapping_for

ARENAS = Path(__file__).resolve().parents[1] / "configs" / "arenas"
STILL = np.zeros(8, np.float32)
# every newer kind, with one of the nine sign boards standing for them all (the others differ only in symbol)
TESTED = [kind for kind in sorted(REGISTRY) if not kind.startswith("sign_") or kind == "sign_tick"]


def example(kind: str, x: float, y: float, yaw: float = 0.0) -> ObjectSpec:
    """An object of a newer kind standing at (x, y), of a size the tests can see and touch."""
    cls = REGISTRY[kind]
    if cls.zone:
        return ObjectSpec(kind, "box", (x, y, ZONE_THICKNESS / 2), (6.0, 6.0, ZONE_THICKNESS), yaw)
    if cls.timed:
        rising = {"start": 1.0, "end": 3.0, "delay": 1.0, "duration": 2.0}
        timing = rising if cls.rising else {**rising, "start": 3.0, "end": 1.0}
        return ObjectSpec(kind, "sphere", (x, y, 1.5), (3.0, 3.0, 3.0), yaw, timing=timing)
    if cls.shape == "sphere":
        return ObjectSpec(kind, "sphere", (x, y, 1.5), (3.0, 3.0, 3.0), yaw)
    if "tunnel" in kind:
        return ObjectSpec(kind, "box", (x, y, 4.0), (4.0, 16.0, 8.0), yaw)
    if kind == "ramp":
        return ObjectSpec(kind, "box", (x, y, 1.5), (6.0, 6.0, 3.0), yaw)
    if kind.startswith("sign_"):
        return ObjectSpec(kind, "box", (x, y, 3.0), (0.4, 6.0, 6.0), yaw)
    return ObjectSpec(kind, "box", (x, y, 2.0), (6.0, 6.0, 4.0), yaw)


def first_step(env, spec):
    env.reset(seed=0, options={"spec": spec, "check": False})
    return env.step(STILL)


# --- the camera agrees with the task ----------------------------------------------------
def green_pixels(image: np.ndarray) -> int:
    r, g, b = (image[:, :, i].astype(int) for i in range(3))
    return int(((g > 100) & (g > r + 50) & (g > b + 50)).sum())


@pytest.mark.parametrize("look, seen", [("task", True), ("classic", False)])
def test_food_behind_a_transparent_wall_shows_in_the_camera_with_the_task_look(make_env, look, seen):
    env = make_env(camera=True, camera_resolution=84, camera_look=look)
    spec = open_arena(
        ObjectSpec("transparent_wall", "box", (8.0, 0.0, 2.0), (1.0, 24.0, 4.0)), sphere("food_green", 16.0, 0.0, 3.0)
    )
    observation, _ = env.reset(seed=0, options={"spec": spec})
    assert (green_pixels(observation["camera"]) > 20) is seen
    hit = env.step(STILL)[0]  # still solid for the rays
    middle = hit["camera"].shape[0] // 2
    assert middle >= 0


def test_a_transparent_wall_stays_solid_for_the_rays_and_the_body(make_env):
    env = make_env(rays=True, camera=True, camera_resolution=16, camera_look="task")
    spec = open_arena(
        ObjectSpec("transparent_wall", "box", (8.0, 0.0, 2.0), (1.0, 24.0, 4.0)), sphere("food_green", 16.0, 0.0, 3.0)
    )
    observation, _ = env.reset(seed=0, options={"spec": spec})
    forward = observation["rays"][observation["rays"].shape[0] // 2]
    assert forward[KINDS.index("transparent_wall")] == 1.0 and forward[-1] < 1.0


@pytest.mark.parametrize("look", ["task", "classic"])
def test_l11_terrain_has_the_floor_colour_in_the_camera_with_the_task_look(make_env, look):
    env = make_env(camera=True, camera_resolution=64, camera_look=look)
    spec = load_arena(ARENAS / "l11_bumpy_floor.yaml", 0)
    observation, _ = env.reset(seed=0, options={"spec": spec})
    ground = observation["camera"][40:].reshape(-1, 3).astype(int)
    floor = np.array(COLOURS["floor"][:3])
    shade = ground / np.maximum(ground.sum(axis=1, keepdims=True), 1)  # the hue, whatever the lighting
    floor_like = (np.abs(shade - floor / floor.sum()) < 0.03).all(axis=1)
    if look == "task":
        assert floor_like.mean() > 0.95
    else:  # TinyRenderer's checker texture: half the terrain blue-grey
        assert floor_like.mean() < 0.8


@pytest.mark.parametrize("kind", TESTED)
def test_every_newer_kind_shows_in_the_camera_in_its_colour(make_env, kind):
    env = make_env(camera=True, camera_resolution=48, camera_look="task")
    spec = open_arena(example(kind, 14.0, 0.0, yaw=math.pi / 2 if "tunnel" in kind else 0.0))
    observation, _ = env.reset(seed=0, options={"spec": spec, "check": False})
    image = observation["camera"].reshape(-1, 3).astype(int)
    blank, _ = env.reset(seed=0, options={"spec": open_arena()})
    changed = np.abs(image - blank["camera"].reshape(-1, 3).astype(int)).sum(axis=1) > 30
    colour = np.array(REGISTRY[kind].colour[:3]) * 255
    hue = image / np.maximum(image.sum(axis=1, keepdims=True), 1)
    near = (np.abs(hue - colour / max(colour.sum(), 1)) < 0.05).all(axis=1) & (image.sum(axis=1) > 60)
    if REGISTRY[kind].camera_hidden:  # seen through, as a transparent wall
        assert changed.sum() <= 2
        return
    assert (near & changed).sum() >= 10, f"{kind}: {(near & changed).sum()} new pixels of its colour"
    assert (near & changed).sum() >= 0.5 * changed.sum()  # what it adds to the picture is mostly its colour


# --- rules: the body put into contact -------------------------------------------------
def test_bad_food_touched_costs_its_size_and_ends_the_episode(make_env):
    env = make_env(limb_food_reward="none")
    spec = open_arena(sphere("bad_food", 2.7, 0.0, 3.0), sphere("food_green", -15.0, 15.0, 3.0))
    _, reward, terminated, truncated, info = first_step(env, spec)
    assert terminated and not truncated
    assert info["reward_terms"]["food"] == -3.0 and info["food_eaten"] == 0
    assert reward < -3.0


def test_bad_food_touched_by_a_leg_alone_still_costs_its_size(make_env):
    env = make_env(limb_food_reward="none")
    env.reset(seed=0, options={"spec": open_arena()})
    foot = env.snapshot().legs[0].foot  # the front-left foot of the resting X, away from the head
    away = 1.2 / math.hypot(foot[0], foot[1])  # the piece overlaps the foot by 0.3
    spec = open_arena(
        sphere("bad_food", foot[0] * (1 + away), foot[1] * (1 + away), 3.0), sphere("food_green", -15.0, 15.0, 3.0)
    )
    _, _, terminated, _, info = first_step(env, spec)
    for _ in range(5):
        if terminated:
            break
        _, _, terminated, _, info = env.step(STILL)
    assert terminated and info["reward_terms"]["food"] == -3.0


def test_multi_food_pays_its_size_and_the_episode_ends_when_all_of_it_is_eaten(make_env):
    env = make_env(limb_food_reward="none")
    spec = open_arena(sphere("multi_food", 2.7, 0.0, 3.0), sphere("food_green", -15.0, 15.0, 3.0))
    _, _, terminated, _, info = first_step(env, spec)
    assert info["reward_terms"]["food"] == 3.0 and info["food_eaten"] == 1
    assert terminated  # the green is left, but every multi piece is eaten
    spec = open_arena(sphere("multi_food", 2.7, 0.0, 3.0), sphere("multi_food", -15.0, 15.0, 3.0))
    _, _, terminated, _, info = first_step(env, spec)
    assert info["reward_terms"]["food"] == 3.0 and not terminated and len(env.world.food) == 1


def test_a_hot_zone_makes_every_step_ten_times_as_costly_while_touched(make_env):
    env = make_env(max_steps=100)
    _, _, terminated, _, cool = first_step(env, open_arena(sphere("food_green", -15.0, 15.0, 3.0)))
    spec = open_arena(example("hot_zone", 0.0, 0.0), sphere("food_green", -15.0, 15.0, 3.0))
    _, _, terminated, _, hot = first_step(env, spec)
    assert not terminated
    assert hot["reward_terms"]["step"] == pytest.approx(HOT_ZONE_FACTOR * cool["reward_terms"]["step"])
    assert cool["reward_terms"]["step"] == pytest.approx(-0.5 / 100)


def test_a_death_zone_touched_is_a_fall(make_env):
    env = make_env()
    spec = open_arena(example("death_zone", 0.0, 0.0), sphere("food_green", -15.0, 15.0, 3.0))
    _, _, terminated, _, info = first_step(env, spec)
    assert terminated and info["fell"] and info["reward_terms"]["fall"] == -1.0


@pytest.mark.parametrize(
    "kind",
    ["decoy", "ramp", "tunnel", "transparent_tunnel", "l_block", "j_block", "u_block", "hollow_box", "sign_tick"],
)
def test_touching_a_solid_newer_kind_pays_nothing_and_ends_nothing(make_env, kind):
    env = make_env()
    obj = example(kind, 4.0, 0.0)
    obj = ObjectSpec(
        obj.kind,
        obj.shape,
        (2.7 + obj.size[0] / 2 - 0.3 if obj.shape == "box" else 2.7, 0.0, obj.position[2]),
        obj.size,
        math.pi / 2 if "tunnel" in kind else 0.0,
    )
    spec = open_arena(obj, sphere("food_green", -15.0, 15.0, 3.0))
    _, _, terminated, _, info = first_step(env, spec)
    for _ in range(10):
        _, _, terminated, _, info = env.step(STILL)
    assert not terminated
    assert info["reward_terms"]["food"] == 0 and info["reward_terms"]["wall"] == 0 and info["reward_terms"]["fall"] == 0


# --- rays -------------------------------------------------------------------------------
@pytest.mark.parametrize("ray_kinds", ["classic", "all"])
def test_rays_see_each_newer_kind_on_its_channel(make_env, ray_kinds):
    env = make_env(rays=True, ray_kinds=ray_kinds, rays_per_side=4, ray_length=20.0)
    names, _ = ray_channels(ray_kinds)
    assert env.observation_space["rays"].shape == (9, len(names) + 2)
    for kind in TESTED:
        cls = REGISTRY[kind]
        # a tunnel turned across the ray: the ray meets its side, not its mouth
        obj = example(kind, 14.0 if "tunnel" in kind else 10.0, 0.0, yaw=math.pi / 2 if "tunnel" in kind else 0.0)
        observation, _ = env.reset(seed=0, options={"spec": open_arena(obj), "check": False})
        forward = observation["rays"][4]
        channel = kind if ray_kinds == "all" and cls.own_channel else cls.classic
        assert forward[names.index(channel)] == 1.0, f"{kind} on {channel}: {forward}"
        assert forward[:-1].sum() == 1.0 and 0.0 < forward[-1] < 1.0


def test_classic_rays_keep_their_width_and_all_adds_a_channel_per_kind_to_tell_apart():
    assert len(ray_channels("classic")[0]) == 9
    names = ray_channels("all")[0]
    assert names[:9] == KINDS and {"bad_food", "multi_food", "hot_zone", "death_zone", "tunnel", "ramp"} <= set(names)
    assert "l_block" not in names  # seen as a wall
    env = AnimalAIEnv(ray_kinds="all")
    try:
        assert env.observation_space["rays"].shape == (17, len(names) + 2)
    finally:
        env.close()
    with pytest.raises(ConfigError, match="ray_kinds"):
        AnimalAIEnv(ray_kinds="some")


# --- viewer, validation, the reference ------------------------------------------------------
@pytest.mark.parametrize("kind", TESTED)
def test_the_viewer_draws_and_marks_each_newer_kind(kind):
    obj = example(kind, 10.0, 0.0)
    plain = draw_top_down(open_arena(), 320)
    picture = draw_top_down(open_arena(obj), 320)
    m = mapping_for(open_arena(), 320)
    col, row = m.to_px(10.0, 0.0)
    window = (slice(row - 20, row + 21), slice(col - 20, col + 21))
    changed = np.abs(picture[window].astype(int) - plain[window].astype(int)).sum(axis=2) > 30
    assert changed.sum() > 40
    colour = np.array([round(255 * c) for c in REGISTRY[kind].colour[:3]])
    assert (np.abs(picture[window].astype(int) - colour).sum(axis=2) < 40).any()
    mark = REGISTRY[kind].mark
    if mark in ("cross", "dot", "arrow", "clock"):  # white on the object
        assert (picture[window] == 255).all(axis=2).any()


def test_validation_keeps_the_body_clear_of_bad_food_and_death_zones_and_goes_through_tunnels():
    band = [ObjectSpec("death_zone", "box", (0.0, 0.0, ZONE_THICKNESS / 2), (50.0, 4.0, ZONE_THICKNESS))]
    spec = open_arena(*band, sphere("food_green", 0.0, 15.0, 3.0), agent=(0.0, -15.0, 0.0))
    assert any("cannot be reached" in problem for problem in validate.check(spec))
    wall = [
        ObjectSpec("wall", "box", (-17.35, 0.0, 2.0), (15.3, 1.0, 4.0)),
        ObjectSpec("wall", "box", (17.35, 0.0, 2.0), (15.3, 1.0, 4.0)),
    ]
    tunnel = ObjectSpec("tunnel", "box", (0.0, 0.0, 4.5), (10.0, 18.0, 9.0), math.pi / 2)
    plug = ObjectSpec("wall", "box", (0.0, 0.0, 2.0), (18.0, 1.0, 4.0))
    food, agent = sphere("food_green", 0.0, 15.0, 3.0), (0.0, -15.0, 0.0)
    assert validate.check(open_arena(*wall, tunnel, food, agent=agent)) == []
    assert validate.check(open_arena(*wall, plug, food, agent=agent)) != []
    assert validate.check(open_arena(sphere("bad_food", 0.0, 0.0, 3.0), food, agent=agent)) == []  # round it
    bad = ObjectSpec("hot_zone", "box", (0.0, 0.0, 1.0), (4.0, 4.0, 2.0))
    assert any("slab on the floor" in problem for problem in validate.check(open_arena(bad, food)))


def test_reference_goes_through_the_tunnel_to_the_food(make_env):
    from aaai.task.reference import ReferenceController

    env = make_env(action_mode="gait")
    spec = load_arena(ARENAS / "animalai" / "tunnel.yaml", 0)
    observation, _ = env.reset(seed=0, options={"spec": spec})
    controller = ReferenceController(env)
    controller.reset(0)
    inside = False
    for _ in range(3000):
        observation, reward, terminated, truncated, info = env.step(controller(observation))
        head = env.body.head_pose()[0]
        inside |= abs(head[0]) < 8.0 and abs(head[1]) < 5.0
        if terminated or truncated:
            break
    assert terminated and info["food_eaten"] == 1 and inside


@pytest.mark.long
@pytest.mark.parametrize("path", sorted((ARENAS / "animalai").glob("*.yaml")), ids=lambda p: p.stem)
def test_reference_passes_the_animal_ai_style_arenas(make_env, path):
    from aaai.task.reference import ReferenceController
    from aaai.tools.animalai_coverage import passed

    env = make_env(action_mode="gait")
    for seed in (0, 1, 2):
        spec = load_arena(path, seed)
        observation, _ = env.reset(seed=seed, options={"spec": spec})
        controller = ReferenceController(env)
        controller.reset(seed)
        total = 0.0
        while True:
            observation, reward, terminated, truncated, info = env.step(controller(observation))
            total += reward
            if terminated or truncated:
                break
        assert passed(total, spec), f"{path.name} seed {seed}: return {total:.2f} of {info['max_reward']:.2f}"


def test_every_kind_is_listed_once_with_a_colour():
    assert len(set(ALL_KINDS)) == len(ALL_KINDS) and all(kind in COLOURS for kind in ALL_KINDS)


def test_bouncing_food_goes_straight_and_comes_back_off_a_wall(make_env):
    env = make_env()
    food = ObjectSpec(
        "food_green",
        "sphere",
        (10.0, 15.0, 1.5),
        (3.0, 3.0, 3.0),
        behaviour={"type": "bounce", "speed": 5.0, "heading": 0.0},
    )
    env.reset(seed=0, options={"spec": open_arena(food)})
    xs, ys = [], []
    for _ in range(250):  # 5 s: 15 units east to the wall (at 25 less its radius), then back
        env.step(STILL)
        x, y, _ = env.world.food_positions()[0]
        xs.append(x)
        ys.append(y)
    turn = int(np.argmax(xs))
    assert 23.0 < xs[turn] <= 23.5 and xs[-1] < xs[turn] - 5.0
    assert max(ys) - min(ys) < 1e-9  # a straight line, reflected


def test_a_sign_shows_its_symbol_to_the_camera_and_symbols_differ(make_env):
    env = make_env(camera=True, camera_resolution=64, camera_look="task")
    seen = {}
    for kind in ("sign_cross", "sign_circle", "sign_left_arrow"):
        spec = open_arena(ObjectSpec(kind, "box", (10.0, 0.0, 3.0), (0.4, 6.0, 6.0)))
        observation, _ = env.reset(seed=0, options={"spec": spec})
        image = observation["camera"].astype(int)
        dark = image.sum(axis=2) < 120  # the symbol's squares
        assert dark.sum() > 20, kind
        seen[kind] = dark
    assert (seen["sign_cross"] != seen["sign_circle"]).sum() > 20
    assert (seen["sign_left_arrow"] != np.fliplr(seen["sign_left_arrow"])).sum() > 20  # not its own mirror image
