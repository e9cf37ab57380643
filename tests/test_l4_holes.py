"""L4, avoidance, by running physics: each hole is a tile of floor that is not there. Probed
straight down a hair either side of each of its edges, the floor is there inside the neighbouring
tile and not past the edge; the body put over a hole falls and the episode ends with the fall's
cost; the start holds the body."""

import pybullet as p
import pytest

from aaai.sim.world import DEADLY_FLOOR_TOP
from aaai.spec.kinds import KIND_INDEX

HAIR = 0.05
KINDS_BY_INDEX = {KIND_INDEX[kind]: kind for kind in ("floor", "deadly_floor")}


def floor_below(env, x: float, y: float):
    """What a ray straight down at (x, y) meets first: "floor", "deadly_floor" (the drop) or None."""
    body = p.rayTest((x, y, 3.0), (x, y, DEADLY_FLOOR_TOP - 1.0), physicsClientId=env.client)[0][0]
    return None if body < 0 else KINDS_BY_INDEX.get(int(env.world.kind_index[body]))


def tile_box(spec, i: int, j: int):
    nx, ny = spec.tiles
    w, h = spec.arena_size[0] / nx, spec.arena_size[1] / ny
    x0, y0 = -spec.arena_size[0] / 2 + i * w, -spec.arena_size[1] / 2 + j * h
    return x0, y0, x0 + w, y0 + h


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l4_the_floor_ends_at_each_holes_edge_to_a_hair(make_env, difficulty):
    env = make_env()
    env.reset(seed=2, options={"level": 4, "difficulty": difficulty})
    spec = env.level_spec
    assert spec.holes
    nx, ny = spec.tiles
    probed = 0
    for i, j in spec.holes:
        x0, y0, x1, y1 = tile_box(spec, i, j)
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        assert floor_below(env, mx, my) == "deadly_floor", (i, j)  # nothing under the hole's middle but the drop
        # each edge shared with a tile that is there: floor a hair outside it, none a hair inside
        for (ni, nj), outside, inside in (
            ((i - 1, j), (x0 - HAIR, my), (x0 + HAIR, my)),
            ((i + 1, j), (x1 + HAIR, my), (x1 - HAIR, my)),
            ((i, j - 1), (mx, y0 - HAIR), (mx, y0 + HAIR)),
            ((i, j + 1), (mx, y1 + HAIR), (mx, y1 - HAIR)),
        ):
            if 0 <= ni < nx and 0 <= nj < ny and (ni, nj) not in spec.holes:
                assert floor_below(env, *outside) == "floor", ((i, j), outside)
                assert floor_below(env, *inside) == "deadly_floor", ((i, j), inside)
                probed += 1
    assert probed >= 2


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l4_the_body_put_over_any_hole_falls_and_the_episode_ends_with_the_fall_cost(make_env, difficulty):
    env = make_env()
    options = {"level": 4, "difficulty": difficulty}
    env.reset(seed=2, options=options)
    for tile in env.level_spec.holes:
        env.reset(seed=2, options=options)
        x0, y0, x1, y1 = tile_box(env.level_spec, *tile)
        p.resetBasePositionAndOrientation(
            env.body.id, ((x0 + x1) / 2, (y0 + y1) / 2, 1.5), (0, 0, 0, 1), physicsClientId=env.client
        )
        for _ in range(200):  # 4 simulated seconds at most
            _, reward, terminated, truncated, info = env.step(env.body.rest_action())
            if terminated or truncated:
                break
        assert terminated and not truncated and info["fell"], tile
        assert info["reward_terms"]["fall"] == -1.0 and reward < -0.99


@pytest.mark.parametrize("difficulty", [0, 5, 10])
def test_l4_the_body_stands_at_its_start_and_the_floor_holds_it(make_env, difficulty):
    env = make_env()
    env.reset(seed=2, options={"level": 4, "difficulty": difficulty})
    for _ in range(100):
        _, _, terminated, truncated, info = env.step(env.body.rest_action())
        assert not (terminated or truncated or info["fell"])
    assert env.body.head_pose()[0][2] > 1.0
