"""The observation's values, sense by sense, in a bare PyBullet world with boxes where the test puts
them: each ray's kind flag and distance, the down fan, floor areas, the camera, its blackout, the
rays' memory of food, joints, tilt and feet."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pybullet as p
import pytest

from aaai.config import SensorsConfig, load_config
from aaai.sim.sensors import EYE_OFFSET, Blackout, Camera, RayMemory, Rays, Senses
from aaai.spec import Blackout as Schedule
from aaai.spec.kinds import KIND_INDEX

GREEN, YELLOW, WALL = KIND_INDEX["food_green"], KIND_INDEX["food_yellow"], KIND_INDEX["wall"]
HOT = KIND_INDEX["hot_zone"]
LENGTH = 10.0


@pytest.fixture
def world():
    """A DIRECT client; ``box(x, y, z, half)`` adds a static box and returns its body id."""
    client = p.connect(p.DIRECT)

    def box(x, y, z=0.0, half=(0.5, 0.5, 0.5)):
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
        return p.createMultiBody(0, shape, basePosition=[x, y, z], physicsClientId=client)

    yield SimpleNamespace(client=client, box=box)
    p.disconnect(client)


def yaw(angle_degrees: float) -> np.ndarray:
    quaternion = p.getQuaternionFromEuler([0.0, 0.0, math.radians(angle_degrees)])
    return np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)


def nothing(n_kinds: int) -> list[float]:
    return [0.0] * n_kinds + [1.0, 1.0]


def test_the_fan_runs_from_right_to_left_and_reads_kind_and_distance_from_the_eye(world):
    ahead, left = world.box(5.0, 0.0), world.box(0.0, 3.0)
    rays = Rays(world.client, 2, 90.0, LENGTH)  # -90, -45, 0, 45, 90 degrees
    obs = rays.observe(np.zeros(3), np.eye(3), np.array([WALL, GREEN]))
    k = rays.n_kinds
    assert obs.shape == (5, k + 2) and obs.dtype == np.float32
    expected = np.array([nothing(k)] * 5, np.float32)
    expected[2, -2:] = expected[4, -2:] = 0.0
    expected[2, WALL], expected[2, -1] = 1.0, (5.0 - 0.5 - EYE_OFFSET) / LENGTH
    expected[4, GREEN], expected[4, -1] = 1.0, (3.0 - 0.5 - EYE_OFFSET) / LENGTH
    np.testing.assert_allclose(obs, expected, atol=1e-6)
    assert (ahead, left) == (0, 1)
    # the head turned 90 degrees left: the box on the left is ahead, the one ahead on the right
    turned = rays.observe(np.zeros(3), yaw(90.0), np.array([WALL, GREEN]))
    assert turned[2, GREEN] == 1.0 and turned[0, WALL] == 1.0
    assert turned[0, -1] == pytest.approx((5.0 - 0.5 - EYE_OFFSET) / LENGTH, abs=1e-6)
    # from elsewhere: the distance is from this eye
    moved = rays.observe(np.array([2.0, 0.0, 0.0]), np.eye(3), np.array([WALL, GREEN]))
    assert moved[2, -1] == pytest.approx((3.0 - 0.5 - EYE_OFFSET) / LENGTH, abs=1e-6)


def test_the_fans_angles_and_length_are_the_configs(world):
    world.box(4.0, 4.0)  # 45 degrees left, 5.66 away
    narrow = Rays(world.client, 1, 45.0, LENGTH)  # -45, 0, 45
    obs = narrow.observe(np.zeros(3), np.eye(3), np.array([WALL]))
    assert obs[2, WALL] == 1.0 and obs[0, -1] == 1.0 and obs[1, -1] == 1.0
    short = Rays(world.client, 1, 45.0, 3.0)  # the box's near side is 4.95 - EYE_OFFSET = 3.40 along the ray
    assert short.observe(np.zeros(3), np.eye(3), np.array([WALL]))[2, -1] == 1.0
    assert Rays(world.client, 1, 45.0, 3.5).observe(np.zeros(3), np.eye(3), np.array([WALL]))[2, -1] < 1.0
    wide = Rays(world.client, 1, 46.0, LENGTH)
    assert wide.observe(np.zeros(3), np.eye(3), np.array([WALL]))[2, WALL] == 1.0  # still on the box
    assert wide.observe(np.zeros(3), yaw(30.0), np.array([WALL]))[1, WALL] == 0.0


def test_a_body_of_no_kind_or_unknown_to_the_env_reads_as_nothing(world):
    world.box(5.0, 0.0)
    rays = Rays(world.client, 1, 45.0, LENGTH)
    k = rays.n_kinds
    for kind_index in (np.array([-1]), np.array([], dtype=int)):
        assert rays.observe(np.zeros(3), np.eye(3), kind_index)[1].tolist() == nothing(k)


def test_flat_rays_are_the_grid_row_by_row_and_the_space_says_so(world):
    world.box(5.0, 0.0)
    grid = Rays(world.client, 2, 60.0, LENGTH)
    flat = Rays(world.client, 2, 60.0, LENGTH, flat=True)
    k = grid.n_kinds
    assert grid.space.shape == (5, k + 2) and flat.space.shape == (5 * (k + 2),)
    for space in (grid.space, flat.space):
        assert space.dtype == np.float32 and (space.low == 0.0).all() and (space.high == 1.0).all()
    kinds = np.array([WALL])
    np.testing.assert_array_equal(
        flat.observe(np.zeros(3), np.eye(3), kinds), grid.observe(np.zeros(3), np.eye(3), kinds).reshape(-1)
    )
    assert Rays(world.client, 2, 60.0, LENGTH, ray_kinds="all").n_kinds > k


def test_the_down_fan_is_the_same_fan_pitched_below_the_head(world):
    world.box(0.0, 0.0, -12.0, half=(20.0, 20.0, 10.0))  # a floor whose top is 2 below the head
    rays = Rays(world.client, 1, 45.0, LENGTH, down_fan=30.0)
    assert rays.n_rays == 6 and rays.space.shape == (6, rays.n_kinds + 2)
    obs = rays.observe(np.zeros(3), np.eye(3), np.array([WALL]))
    assert (obs[:3, -1] == 1.0).all()  # the level fan passes over the floor
    along = 2.0 / math.sin(math.radians(30.0)) - EYE_OFFSET  # every pitched ray, whatever its angle
    np.testing.assert_allclose(obs[3:, -1], along / LENGTH, atol=1e-6)
    assert (obs[3:, WALL] == 1.0).all()
    world.box(3.0, 3.0, 0.0)  # 45 degrees left, level with the head: the level fan's row 2 only
    obs = rays.observe(np.zeros(3), np.eye(3), np.array([WALL, GREEN]))
    assert obs[2, GREEN] == 1.0 and obs[5, GREEN] == 0.0
    assert Rays(world.client, 1, 45.0, LENGTH, down_fan=0.0).n_rays == 3


def zone_row(x, y, yaw_radians, half_x, half_y, kind=HOT):
    return (x, y, yaw_radians, half_x, half_y, kind)


def test_floor_areas_are_seen_along_the_ground_where_the_track_enters_them(world):
    rays = Rays(world.client, 1, 45.0, LENGTH)
    kinds = np.array([WALL])
    column = rays.column[HOT]
    rays.set_zones([zone_row(5.0, 0.0, 0.0, 1.0, 1.0)])
    obs = rays.observe(np.zeros(3), np.eye(3), kinds)
    expected = [0.0] * (rays.n_kinds + 2)
    expected[column], expected[-1] = 1.0, (4.0 - EYE_OFFSET) / LENGTH
    np.testing.assert_allclose(obs[1], expected, atol=1e-6)
    assert obs[0].tolist() == nothing(rays.n_kinds) and obs[2].tolist() == nothing(rays.n_kinds)
    # turned 45 degrees, the square's nearest corner is on the forward ray
    rays.set_zones([zone_row(5.0, 0.0, math.pi / 4, 1.0, 1.0)])
    along = rays.observe(np.zeros(3), np.eye(3), kinds)[1, -1] * LENGTH
    assert along == pytest.approx(5.0 - math.sqrt(2.0) - EYE_OFFSET, abs=1e-6)
    # a long thin area along y, turned 90 degrees, lies along x: only the forward ray meets it
    rays.set_zones([zone_row(5.0, 0.0, math.pi / 2, 0.2, 2.0)])
    obs = rays.observe(np.zeros(3), np.eye(3), kinds)
    assert obs[1, -1] * LENGTH == pytest.approx(3.0 - EYE_OFFSET, abs=1e-6) and obs[2, -1] == 1.0
    # the nearest of two; one behind the eye is never seen; under the eye: at once
    rays.set_zones([zone_row(8.0, 0.0, 0.0, 1.0, 1.0, KIND_INDEX["death_zone"]), zone_row(5.0, 0.0, 0.0, 1.0, 1.0)])
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1, column] == 1.0
    rays.set_zones([zone_row(-5.0, 0.0, 0.0, 1.0, 1.0)])
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1].tolist() == nothing(rays.n_kinds)
    rays.set_zones([zone_row(1.0, 0.0, 0.0, 1.0, 1.0)])  # the forward ray starts inside; the others leave it
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[:, -1].tolist() == [1.0, 0.0, 1.0]
    rays.set_zones([])
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1].tolist() == nothing(rays.n_kinds)


def test_a_floor_area_beyond_a_wall_is_hidden_and_one_before_it_shows(world):
    world.box(4.0, 0.0)  # its face 3.5 ahead
    rays = Rays(world.client, 1, 45.0, LENGTH)
    kinds = np.array([WALL])
    rays.set_zones([zone_row(6.0, 0.0, 0.0, 1.0, 1.0)])
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1, WALL] == 1.0
    rays.set_zones([zone_row(2.5, 0.0, 0.0, 0.5, 0.5)])
    obs = rays.observe(np.zeros(3), np.eye(3), kinds)
    assert obs[1, WALL] == 0.0 and obs[1, rays.column[HOT]] == 1.0
    assert obs[1, -1] == pytest.approx((2.0 - EYE_OFFSET) / LENGTH, abs=1e-6)


def test_a_ray_level_with_a_side_of_an_area_does_not_divide_by_zero(world):
    rays = Rays(world.client, 1, 90.0, LENGTH)  # -90, 0, 90: each parallel to two sides
    rays.set_zones([zone_row(0.0, 5.0, 0.0, 1.0, 1.0)])
    with np.errstate(all="raise"):
        obs = rays.observe(np.zeros(3), np.eye(3), np.array([WALL]))
    assert obs[2, -1] == pytest.approx((4.0 - EYE_OFFSET) / LENGTH, abs=1e-6) and obs[1, -1] == 1.0


@pytest.mark.parametrize(
    "light, dark, dt, darks",
    [
        (2.0, 1.0, 0.5, [4, 5, 10, 11]),  # 4 steps light, 2 dark, repeating
        (0.74, 0.26, 0.5, [1, 3, 5, 7, 9, 11]),  # rounded to whole steps: 1 light, 1 dark
        (0.0, 1.0, 1.0, list(range(12))),  # never light
    ],
)
def test_the_blackout_is_dark_exactly_on_its_steps(light, dark, dt, darks):
    blackout = Blackout(Schedule(light, dark), dt)
    assert [step for step in range(12) if blackout.dark(step)] == darks
    assert not any(Blackout().dark(step) for step in range(12))
    assert not any(Blackout(None, 0.5).dark(step) for step in range(12))


def food_rays(rays: Rays, seen: dict) -> np.ndarray:
    """A rays observation: nothing everywhere except ``seen`` rows {row: (kind, distance)}."""
    grid = np.zeros(rays.grid_shape, np.float32)
    grid[:, rays.n_kinds] = grid[:, -1] = 1.0
    for row, (kind, distance) in seen.items():
        grid[row, :] = 0.0
        grid[row, rays.column[kind]], grid[row, -1] = 1.0, distance
    return grid


def test_the_memory_recalls_food_1_2_and_4_steps_back_and_nothing_else(world):
    rays = Rays(world.client, 1, 45.0, LENGTH)  # 3 rays
    memory = RayMemory(rays, 3)
    assert memory.space.shape == (3, 3, 3) and memory.lags.tolist() == [1, 2, 4]
    blank = np.array([[0.0, 0.0, 1.0]] * 3, np.float32)
    steps = [
        food_rays(rays, {0: (GREEN, 0.25), 2: (WALL, 0.5)}),  # the wall is not remembered
        food_rays(rays, {1: (YELLOW, 0.75)}),
        food_rays(rays, {}),
        food_rays(rays, {}),
        food_rays(rays, {}),
    ]
    recalled = [memory.recall(step) for step in steps]
    assert (recalled[0] == blank).all()  # before the episode: no food, distance 1
    green = blank.copy()
    green[0] = [1.0, 0.0, 0.25]
    yellow = blank.copy()
    yellow[1] = [0.0, 1.0, 0.75]
    np.testing.assert_array_equal(recalled[1], [green, blank, blank])
    np.testing.assert_array_equal(recalled[2], [yellow, green, blank])
    np.testing.assert_array_equal(recalled[3], [blank, yellow, blank])
    np.testing.assert_array_equal(recalled[4], [blank, blank, green])  # 4 steps back
    flat = Rays(world.client, 1, 45.0, LENGTH, flat=True)
    flat_memory = RayMemory(flat, 1)
    flat_memory.recall(steps[0].reshape(-1))
    np.testing.assert_array_equal(flat_memory.recall(steps[2].reshape(-1))[0], green)
    memory.clear()
    assert (memory.recall(steps[2]) == blank).all()


class Body:
    """What the senses read of a body: its joints' count and its feet's links."""

    n_axes = 3
    foot_links = [4, 7]
    foot_slot = {4: 0, 7: 1}


def _typed(sensors: dict) -> SensorsConfig:
    """A sensors section: the defaults with these values (no cross-checks: the senses are tested alone)."""
    return dataclasses.replace(load_config().sensors, **sensors)


SENSORS = dict(
    rays=True,
    rays_per_side=1,
    ray_max_angle=45.0,
    ray_length=LENGTH,
    rays_flat=False,
    camera=False,
    camera_resolution=16,
    camera_grayscale=False,
    joint_velocities=False,
    head_orientation=False,
    foot_contacts=False,
)


def test_the_senses_make_the_observation_the_config_asks_for(world):
    bare = Senses(world.client, _typed(SENSORS), Body())
    assert sorted(bare.space) == ["joints", "rays"]
    assert bare.rays.n_kinds == 9 and bare.rays.n_rays == 3 and bare.rays.width == 0.0  # the defaults
    assert bare.memory is None and bare.camera is None
    full = dict(SENSORS, camera=True, joint_velocities=True, head_orientation=True, foot_contacts=True)
    senses = Senses(
        world.client, _typed(dict(full, ray_memory=2, ray_kinds="all", ray_down_fan=10.0, ray_width=0.5)), Body()
    )
    assert sorted(senses.space) == [
        "camera",
        "foot_contacts",
        "head_orientation",
        "joint_velocities",
        "joints",
        "ray_memory",
        "rays",
    ]
    assert senses.rays.n_rays == 6 and senses.rays.n_kinds > 9 and senses.rays.width == 0.5
    assert senses.space["joints"].shape == (3,) and senses.space["joint_velocities"].shape == (3,)
    assert senses.space["foot_contacts"].shape == (2,) and senses.space["head_orientation"].shape == (3,)
    assert senses.space["ray_memory"].shape == (2, 6, 3) and senses.space["camera"].shape == (16, 16, 3)
    assert (senses.space["joints"].low == -1.0).all() and (senses.space["head_orientation"].high == 1.0).all()
    assert np.isinf(senses.space["joint_velocities"].high).all()
    assert (senses.space["foot_contacts"].low == 0.0).all() and (senses.space["foot_contacts"].high == 1.0).all()
    blind = Senses(world.client, _typed(dict(SENSORS, rays=False, ray_memory=2)), Body())
    assert sorted(blind.space) == ["joints"] and blind.memory is None


def test_each_observed_value(world):
    world.box(5.0, 0.0)
    full = dict(SENSORS, camera=True, joint_velocities=True, head_orientation=True, foot_contacts=True, ray_memory=1)
    senses = Senses(world.client, _typed(full), Body())
    angles, speeds = np.array([0.1, -0.2, 0.3]), np.array([1.5, 0.0, -2.5])
    senses.feel([(0, 0, 0, 7, -1), (0, 0, 0, 2, -1)])  # foot 7 touches; link 2 is no foot
    pitched = p.getQuaternionFromEuler([0.0, math.radians(30.0), 0.0])  # nose down 30 degrees
    observation = senses.observe(angles, speeds, (0.0, 0.0, 0.0), pitched, np.array([WALL]), dark=True)
    assert observation["joints"].dtype == np.float32 and observation["joints"].tolist() == pytest.approx(angles)
    assert observation["joint_velocities"].dtype == np.float32
    assert observation["joint_velocities"].tolist() == pytest.approx(speeds)
    # gravity in the head's frame: nose down, it points forward and down
    tilt = observation["head_orientation"]
    assert tilt.dtype == np.float32
    assert tilt.tolist() == pytest.approx([math.sin(math.radians(30.0)), 0.0, -math.cos(math.radians(30.0))], abs=1e-6)
    assert observation["foot_contacts"].tolist() == [0.0, 1.0]
    assert (observation["camera"] == 0).all() and observation["camera"].shape == (16, 16, 3)
    assert observation["ray_memory"].tolist() == [[[0.0, 0.0, 1.0]] * 3]
    level = senses.observe(angles, speeds, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), np.array([WALL]), dark=False)
    assert level["rays"][1, WALL] == 1.0 and level["camera"].any()  # lit: the box in view
    assert level["head_orientation"].tolist() == pytest.approx([0.0, 0.0, -1.0])
    senses.feel([])
    assert senses.observe(angles, speeds, (0, 0, 0), (0, 0, 0, 1), np.array([WALL]), False)["foot_contacts"].sum() == 0
    for alone in (dict(SENSORS), dict(SENSORS, rays=False, head_orientation=True), dict(SENSORS, rays=False)):
        one = Senses(world.client, _typed(alone), Body()).observe(
            angles, speeds, (0, 0, 0), pitched, np.array([WALL]), True
        )
        assert sorted(one) == sorted(Senses(world.client, _typed(alone), Body()).space)
    unfelt = Senses(world.client, _typed(SENSORS), Body())
    unfelt.feel([(0, 0, 0, 7, -1)])
    assert unfelt.feet.tolist() == [0.0, 0.0]  # feet not observed: not worked out


def test_a_new_level_clears_the_feet_and_the_memory_and_learns_its_blackout_and_areas(world):
    from conftest import open_arena

    from aaai.spec import ObjectSpec

    full = dict(SENSORS, foot_contacts=True, ray_memory=1)
    senses = Senses(world.client, _typed(full), Body())
    senses.feel([(0, 0, 0, 4, -1)])
    senses.memory.recall(food_rays(senses.rays, {1: (GREEN, 0.5)}))
    zone = ObjectSpec("hot_zone", "box", (5.0, 0.0, 0.0), (2.0, 2.0, 0.1))
    spec = open_arena(zone, blackout=Schedule(1.0, 1.0))
    senses.start(spec, 0.5)
    assert senses.feet.tolist() == [0.0, 0.0]
    assert senses.memory.recall(food_rays(senses.rays, {})).tolist() == [[[0.0, 0.0, 1.0]] * 3]
    assert [senses.blackout.dark(step) for step in range(4)] == [False, False, True, True]
    obs = senses.rays.observe(np.zeros(3), np.eye(3), np.array([WALL]))
    assert obs[1, senses.rays.column[HOT]] == 1.0
    assert obs[1, -1] == pytest.approx((4.0 - EYE_OFFSET) / LENGTH, abs=1e-6)


def test_the_camera_is_a_60_degree_pinhole_at_the_eye_looking_forward(world):
    world.box(0.0, 0.0, -3.0, half=(200.0, 200.0, 1.0))  # a floor
    world.box(EYE_OFFSET + 0.6, 0.15, 0.0, half=(0.05, 0.05, 0.05))  # near: inside 1 of the eye
    world.box(EYE_OFFSET + 119.7, 0.0, 0.0, half=(0.2, 30.0, 30.0))  # far: just short of 120
    camera = Camera(world.client, 32, grayscale=False)
    assert camera.space.shape == (32, 32, 3) and camera.space.dtype == np.uint8
    image = camera.observe(np.zeros(3), np.eye(3))
    assert image.shape == (32, 32, 3) and image.dtype == np.uint8 and image.flags["C_CONTIGUOUS"]
    eye = np.array([EYE_OFFSET, 0.0, 0.0])
    view = p.computeViewMatrix(eye.tolist(), (eye + [1.0, 0.0, 0.0]).tolist(), [0.0, 0.0, 1.0])
    projection = p.computeProjectionMatrixFOV(60.0, 1.0, 0.05, 120.0)
    _, _, rgba, _, _ = p.getCameraImage(
        32, 32, view, projection, renderer=p.ER_TINY_RENDERER, physicsClientId=world.client
    )
    np.testing.assert_array_equal(image, np.asarray(rgba, np.uint8).reshape(32, 32, 4)[:, :, :3])
    turned = camera.observe(np.zeros(3), yaw(180.0))  # the far wall behind: only the floor
    assert not np.array_equal(turned, image)
    grey = Camera(world.client, 32, grayscale=True)
    assert grey.space.shape == (32, 32, 1)
    weights = np.array([0.299, 0.587, 0.114])  # luma from red, green, blue in that order
    np.testing.assert_allclose(grey.observe(np.zeros(3), np.eye(3))[:, :, 0], image @ weights, atol=1.0)
    assert grey.blank().shape == (32, 32, 1) and not grey.blank().any()


def test_wide_rays_report_the_nearest_known_of_their_three_hits(world):
    """Three rays a side of width 1: the centre one and two 0.5 to its left and right."""
    kinds = []

    def post(x, y, kind, half_y=0.05):
        kinds.append(kind)
        return world.box(x, y, 0.0, half=(0.05, half_y, 0.5))

    rays = Rays(world.client, 1, 90.0, LENGTH, width=1.0)  # -90, 0, 90; row 1 looks along +x
    assert post(4.0, -0.5, GREEN) == 0  # body 0 of kind 0, seen by the right ray alone
    index = np.array(kinds)
    row = rays.observe(np.zeros(3), np.eye(3), index)[1]
    assert row[GREEN] == 1.0 and row[-1] == pytest.approx((4.0 - 0.05 - EYE_OFFSET) / LENGTH, abs=1e-6)

    post(6.0, 0.0, WALL, half_y=0.3)  # farther, in front of the centre ray: the nearer side hit wins
    post(3.0, 0.5, -1)  # nearer, of no kind: not a hit
    row = rays.observe(np.zeros(3), np.eye(3), np.array(kinds))[1]
    assert row[GREEN] == 1.0 and row[WALL] == 0.0
    assert rays.observe(np.zeros(3), np.eye(3), np.array(kinds[1:] + [WALL]))[1, WALL] == 1.0  # body 0 unknown

    post(2.0, 0.5, YELLOW)  # body 3: beyond the list of kinds it is nothing
    row = rays.observe(np.zeros(3), np.eye(3), np.array(kinds[:3]))[1]
    assert row[GREEN] == 1.0 and row[YELLOW] == 0.0
    row = rays.observe(np.zeros(3), np.eye(3), np.array(kinds))[1]  # known: the nearest of all
    assert row[YELLOW] == 1.0 and row[-1] == pytest.approx((2.0 - 0.05 - EYE_OFFSET) / LENGTH, abs=1e-6)


def test_a_side_hit_as_near_as_the_centre_hit_leaves_the_centre_hit(world):
    world.box(5.0, 0.0, 0.0, half=(0.05, 0.3, 0.5))  # the centre ray's wall
    world.box(5.0, 0.5, 0.0, half=(0.05, 0.1, 0.5))  # food with the same front face, left
    world.box(7.0, -0.5, 0.0, half=(0.05, 0.1, 0.5))  # food farther, right
    rays = Rays(world.client, 1, 90.0, LENGTH, width=1.0)
    row = rays.observe(np.zeros(3), np.eye(3), np.array([WALL, GREEN, GREEN]))[1]
    assert row[WALL] == 1.0 and row[GREEN] == 0.0


def march(rays: Rays, zones: list, start: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each ray's first point in a floor area by walking its ground track in steps of 1e-3."""
    t = np.arange(0.0, rays.length, 1e-3)
    distance, kind = np.ones(len(dirs)), np.full(len(dirs), -1)
    for row, direction in enumerate(dirs):
        points = start[:2] + direction[:2] * EYE_OFFSET + t[:, None] * direction[:2]
        for x, y, angle, half_x, half_y, zone_kind in zones:
            dx, dy = points[:, 0] - x, points[:, 1] - y
            u, v = dx * math.cos(angle) + dy * math.sin(angle), -dx * math.sin(angle) + dy * math.cos(angle)
            inside = np.flatnonzero((np.abs(u) <= half_x) & (np.abs(v) <= half_y))
            if len(inside) and t[inside[0]] / rays.length < distance[row]:
                distance[row], kind[row] = t[inside[0]] / rays.length, zone_kind
    return distance, kind


@pytest.mark.parametrize("layout", range(6))
def test_floor_areas_turned_any_way_are_where_walking_the_ground_track_finds_them(world, layout):
    rng = np.random.default_rng(layout)
    rays = Rays(world.client, 4, 180.0, LENGTH, ray_kinds="all")  # every 45 degrees, behind too
    kinds = [HOT, KIND_INDEX["death_zone"], HOT, KIND_INDEX["death_zone"], HOT]
    zones = [
        zone_row(*rng.uniform(-6.0, 6.0, 2), rng.uniform(-math.pi, math.pi), *rng.uniform(0.5, 2.5, 2), kind)
        for kind in kinds
    ]
    rays.set_zones(zones)
    start, rotation = np.array([*rng.uniform(-1.0, 1.0, 2), 0.0]), yaw(rng.uniform(-180.0, 180.0))
    obs = rays.observe(start, rotation, np.array([WALL]))
    distance, kind = march(rays, zones, start, rays.local_dirs @ rotation.T)
    assert (distance < 1.0).sum() >= 3  # the layouts do put areas in the rays' way
    np.testing.assert_allclose(obs[:, -1], distance, atol=2e-3 / LENGTH)
    for row in range(rays.n_rays):
        seen = [rays.column[k] for k in kind[row : row + 1] if k >= 0]
        assert np.flatnonzero(obs[row, :-1]).tolist() == (seen or [rays.n_kinds])


def test_a_ray_square_to_an_area_divides_by_no_zero_and_still_sees_it(world):
    rays = Rays(world.client, 1, 45.0, LENGTH)
    rays.set_zones([zone_row(0.0, 5.0, 0.0, 1.0, 1.0)])
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # exactly 90 degrees left
    with np.errstate(all="raise"):
        obs = rays.observe(np.zeros(3), quarter, np.array([WALL]))
    assert obs[1, rays.column[HOT]] == 1.0
    assert obs[1, -1] == pytest.approx((4.0 - EYE_OFFSET) / LENGTH, abs=1e-6)


def test_an_area_touching_the_track_is_seen_and_one_at_the_rays_end_is_not(world):
    rays = Rays(world.client, 1, 45.0, LENGTH)
    kinds = np.array([WALL])
    rays.set_zones([zone_row(5.0, 0.0, 0.0, 0.0, 1.0)])  # no depth at all: a line across the ray
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1, rays.column[HOT]] == 1.0
    end = EYE_OFFSET + LENGTH  # the ray's end, from the head
    assert (end + 1.0 - 1.0 - EYE_OFFSET) / LENGTH == 1.0
    rays.set_zones([zone_row(end + 1.0, 0.0, 0.0, 1.0, 1.0)])  # from exactly the ray's end on: out of reach
    assert rays.observe(np.zeros(3), np.eye(3), kinds)[1].tolist() == nothing(rays.n_kinds)
    rays.set_zones([zone_row(end + 1.0 - 1e-6, 0.0, 0.0, 1.0, 1.0)])  # a hair nearer: seen
    obs = rays.observe(np.zeros(3), np.eye(3), kinds)
    assert obs[1, rays.column[HOT]] == 1.0 and obs[1, -1] == pytest.approx(1.0 - 1e-7, abs=1e-7)


def test_the_spaces_bounds_and_types(world):
    rays = Rays(world.client, 1, 45.0, LENGTH)
    memory = RayMemory(rays, 2).space
    assert memory.dtype == np.float32 and (memory.low == 0.0).all() and (memory.high == 1.0).all()
    camera = Camera(world.client, 8, grayscale=False)
    assert (camera.space.low == 0).all() and (camera.space.high == 255).all()
    assert camera.blank().dtype == np.uint8 and camera.blank().shape == (8, 8, 3) and not camera.blank().any()


def test_a_centre_hit_of_kind_zero_stands_and_one_of_no_kind_gives_way(world):
    world.box(4.0, 0.0, 0.0, half=(0.05, 0.3, 0.5))  # body 0, on the centre ray
    world.box(6.0, 0.5, 0.0, half=(0.05, 0.1, 0.5))  # body 1, farther, left
    world.box(6.0, -0.5, 0.0, half=(0.05, 0.1, 0.5))  # body 2, as far, right
    rays = Rays(world.client, 1, 90.0, LENGTH, width=1.0)
    row = rays.observe(np.zeros(3), np.eye(3), np.array([GREEN, WALL, -1]))[1]
    assert row[GREEN] == 1.0 and row[-1] == pytest.approx((4.0 - 0.05 - EYE_OFFSET) / LENGTH, abs=1e-6)
    row = rays.observe(np.zeros(3), np.eye(3), np.array([-1, WALL, GREEN]))[1]  # the left one, first of equals
    assert row[WALL] == 1.0 and row[-1] == pytest.approx((6.0 - 0.05 - EYE_OFFSET) / LENGTH, abs=1e-6)
