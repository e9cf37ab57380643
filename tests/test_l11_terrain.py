"""L11, body awareness, by running physics: the ground is where the level's heightfield puts it (a
ray straight down meets it at each sample's height, and a hair in from both ends of the steepest
step between two samples at the height the step gives there), and it is rough: more bumps as the
difficulty grows. The body set down at its start stands on it, upright and at rest, for seconds;
the green rests on the ground (not sunk into a slope), far from the start along validate's path,
and the head put against it eats it."""

import math

import numpy as np
import pybullet as p
import pytest

from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.levels import validate
from aaai.spec.kinds import KIND_INDEX

HAIR = 0.05
SEEDS = (1, 3)


def floor_body(env) -> int:
    (body,) = np.flatnonzero(env.world.kind_index == KIND_INDEX["floor"])  # the terrain is one body
    return int(body)


def ground(env, x: float, y: float) -> float | None:
    """The height a ray straight down at (x, y) meets the ground at (None: it met something else first)."""
    hit = p.rayTest((x, y, 10.0), (x, y, -10.0), physicsClientId=env.client)[0]
    return hit[3][2] if hit[0] >= 0 and env.world.kind_index[hit[0]] == KIND_INDEX["floor"] else None


def samples(env):
    """The heightfield (rows along y, columns along x) and a sample's place in the arena."""
    heights = np.array(env.level_spec.heightfield)
    rows, cols = heights.shape
    width, depth = env.level_spec.arena_size

    def place(i: int, j: int) -> tuple[float, float]:  # column i, row j; the edge samples a hair inside the arena
        x = -width / 2 + i * width / (cols - 1)
        y = -depth / 2 + j * depth / (rows - 1)
        return min(max(x, -width / 2 + 1e-3), width / 2 - 1e-3), min(max(y, -depth / 2 + 1e-3), depth / 2 - 1e-3)

    return heights, place


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", SEEDS)
def test_l11_the_ground_is_where_the_heightfield_puts_it(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 11, "difficulty": difficulty})
    heights, place = samples(env)
    rows, cols = heights.shape
    met = 0
    for j in range(0, rows, 2):
        for i in range(0, cols, 2):
            z = ground(env, *place(i, j))
            if z is not None:  # not under the body or the green
                assert z == pytest.approx(heights[j, i], abs=1e-3), (i, j)
                met += 1
    assert met > 0.9 * math.ceil(rows / 2) * math.ceil(cols / 2)
    # the steepest step between two neighbouring samples (along x, then along y), probed a hair in from each end
    for axis in (1, 0):
        steps = np.abs(np.diff(heights, axis=axis))
        j, i = np.unravel_index(np.argmax(steps), steps.shape)
        (j1, i1) = (j, i + 1) if axis == 1 else (j + 1, i)
        a, b = np.array(place(i, j)), np.array(place(i1, j1))
        length = float(np.linalg.norm(b - a))
        for start, end, h0, h1 in ((a, b, heights[j, i], heights[j1, i1]), (b, a, heights[j1, i1], heights[j, i])):
            x, y = start + (end - start) / length * HAIR
            assert ground(env, x, y) == pytest.approx(h0 + (h1 - h0) * HAIR / length, abs=1e-3), (axis, i, j)
        assert abs(heights[j1, i1] - heights[j, i]) > 0.05  # a step the probes tell from level ground


def bumps(env) -> int:
    """Tops and bottoms the ground has along five lines across the arena (x), measured with rays."""
    heights, place = samples(env)
    rows, cols = heights.shape
    count = 0
    for j in np.linspace(4, rows - 5, 5).astype(int):
        line = [ground(env, *place(i, j)) for i in range(cols)]
        slopes = np.diff([z for z in line if z is not None])
        slopes = slopes[np.abs(slopes) > 1e-3]
        count += int(np.sum(np.sign(slopes[1:]) != np.sign(slopes[:-1])))
    return count


def test_l11_the_ground_has_more_bumps_as_the_difficulty_grows(make_env):
    env = make_env()
    for seed in SEEDS:
        counts = []
        for difficulty in (0, 5, 10):
            env.reset(seed=seed, options={"level": 11, "difficulty": difficulty})
            counts.append(bumps(env))
        assert counts[0] < counts[1] < counts[2], (seed, counts)
        assert counts[0] > 0  # rough even at difficulty 0


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", SEEDS)
def test_l11_the_body_set_down_at_its_start_stands_on_the_ground(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 11, "difficulty": difficulty})
    floor = floor_body(env)
    start = env.body.head_pose()[0]
    gaps, path = [], []
    for _ in range(150):  # three simulated seconds at rest
        _, _, terminated, truncated, info = env.step(env.body.rest_action())
        assert not (terminated or truncated or info["fell"] or info["blew_up"])
        closest = p.getClosestPoints(env.body.id, floor, 5.0, linkIndexA=-1, physicsClientId=env.client)
        gaps.append(min(point[8] for point in closest))  # the head's surface to the ground
        path.append(env.body.head_pose()[0])
    assert info["food_eaten"] == 0  # nothing within reach of the start
    assert min(gaps) > -0.05  # never sunk into the ground
    assert abs(gaps[-1]) < 0.05  # resting on it
    head, rotation = env.body.head_pose()
    assert rotation[2, 2] > 0.8  # upright: the head's up axis within 37 degrees of the world's
    assert np.linalg.norm(head[:2] - start[:2]) < 1.5  # settled where it was set down
    assert np.ptp(np.array(path[-50:]), axis=0).max() < 0.5  # no more than a slow creep down a slope in the last second


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", SEEDS)
def test_l11_the_green_rests_on_the_ground_far_along_the_path_and_is_eaten_on_contact(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 11, "difficulty": difficulty})
    spec = env.level_spec
    (green,) = env.world.food
    piece = env.world.food[green]
    closest = p.getClosestPoints(green, floor_body(env), 5.0, physicsClientId=env.client)
    assert 0.0 <= min(point[8] for point in closest) < piece.size[0] / 4  # on the ground, not in it nor high above
    # validate's path from the start to the green: there is one, and it is long
    assert validate.check(spec) == []
    region, _ = validate.reachable_region(spec)
    reach = HEAD_RADIUS + piece.size[0] / 2
    cols = (np.arange(region.shape[1]) + 0.5) * validate.GRID - spec.arena_size[0] / 2
    rows = (np.arange(region.shape[0]) + 0.5) * validate.GRID - spec.arena_size[1] / 2
    goals = np.hypot(cols[None, :] - piece.position[0], rows[:, None] - piece.position[1]) <= reach
    costs = validate.path_costs(region, goals)
    walk = costs[validate.cell(spec, spec.agent.x, spec.agent.y, region.shape)]
    assert max(spec.arena_size) / 4 < walk < math.inf  # a quarter of the arena's side or more to walk
    # the head put against it from the start's side, a hair inside touching distance, eats it
    target = np.array(piece.position)
    toward = np.array([spec.agent.x, spec.agent.y]) - target[:2]
    toward /= np.linalg.norm(toward)
    head = target + np.array([*toward, 0.0]) * (HEAD_RADIUS + piece.size[0] / 2 - 0.2)
    p.resetBasePositionAndOrientation(env.body.id, head.tolist(), (0, 0, 0, 1), physicsClientId=env.client)
    _, _, terminated, _, info = env.step(env.body.rest_action())
    assert info["food_eaten"] == 1 and terminated
    assert info["reward_terms"]["food"] == pytest.approx(spec.max_food_reward)
