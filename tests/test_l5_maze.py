"""L5, spatial reasoning, by running physics: the maze is read from the built world with rays
(a ray from a chunk's middle to its neighbour's is stopped by a wall unless a passage joins
them), and in that graph the body's start and the green are in the two chunks farthest apart.
Its walls stop the body walking into them; validate's path joins the start to the green."""

import math
from collections import deque

import numpy as np
import pybullet as p
import pytest
from test_behaviours import walk_north

from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.levels import validate

ABOVE_OBSTACLES = 6.0  # the height the rays are cast at: over the 4-high extra obstacles, under the maze's walls


def chunks(env):
    """The chunk grid: (columns, rows, side) and the middle of a chunk (i, j)."""
    maze = env.level_spec.extras["maze"]
    columns, rows = maze["columns"], maze["rows"]
    side = env.level_spec.arena_size[0] / columns

    def middle(i, j):
        return -env.level_spec.arena_size[0] / 2 + (i + 0.5) * side, -env.level_spec.arena_size[1] / 2 + (
            j + 0.5
        ) * side

    return columns, rows, side, middle


def chunk_of(env, x, y):
    _, _, side, _ = chunks(env)
    return int((x + env.level_spec.arena_size[0] / 2) // side), int((y + env.level_spec.arena_size[1] / 2) // side)


def passages(env) -> dict[tuple, set]:
    """Each chunk's neighbours that a ray from its middle reaches unstopped."""
    columns, rows, _, middle = chunks(env)
    graph = {(i, j): set() for i in range(columns) for j in range(rows)}
    for i, j in graph:
        for other in ((i + 1, j), (i, j + 1)):
            if other in graph:
                a, b = middle(i, j), middle(*other)
                hit = p.rayTest((*a, ABOVE_OBSTACLES), (*b, ABOVE_OBSTACLES), physicsClientId=env.client)[0]
                if hit[0] < 0:
                    graph[(i, j)].add(other)
                    graph[other].add((i, j))
                else:  # stopped at the wall line between them: half way, less half its thickness
                    assert hit[2] * math.dist(a, b) == pytest.approx(math.dist(a, b) / 2 - 0.5, abs=1e-6)
    return graph


def distances(graph, source) -> dict[tuple, int]:
    seen, queue = {source: 0}, deque([source])
    while queue:
        cell = queue.popleft()
        for other in graph[cell]:
            if other not in seen:
                seen[other] = seen[cell] + 1
                queue.append(other)
    return seen


@pytest.mark.parametrize("difficulty", [0, 5, 10])
@pytest.mark.parametrize("seed", [6, 7])
def test_l5_start_and_green_are_the_two_chunks_farthest_apart_along_the_maze(make_env, difficulty, seed):
    env = make_env()
    env.reset(seed=seed, options={"level": 5, "difficulty": difficulty})
    graph = passages(env)
    start = chunk_of(env, *env.body.head_pose()[0][:2])
    goal = chunk_of(env, *env.level_spec.foods[0].position[:2])
    reached = distances(graph, start)
    assert goal in reached and goal != start  # joined by passages
    farthest = max(max(distances(graph, cell).values()) for cell in reached)  # the maze's longest path
    assert reached[goal] == farthest
    assert validate.check(env.level_spec) == []  # and the walking body's path from the start to the green exists


@pytest.mark.parametrize("difficulty", [0, 10])
def test_l5_a_maze_wall_stops_the_body_walking_into_it(make_env, difficulty):
    env = make_env(max_steps=5000)
    env.reset(seed=6, options={"level": 5, "difficulty": difficulty})
    graph = passages(env)
    columns, rows, side, middle = chunks(env)
    # a chunk of the maze with a wall on its north side, though not the arena's: walk north at it
    cell = next(
        (i, j) for (i, j), joined in sorted(graph.items()) if j + 1 < rows and (i, j + 1) not in joined and joined
    )
    x, y = middle(*cell)
    wall_face = y + side / 2 - 0.5
    p.resetBasePositionAndOrientation(
        env.body.id, (x, y - 5.0, 1.5), p.getQuaternionFromEuler((0, 0, math.pi / 2)), physicsClientId=env.client
    )
    _, info, head = walk_north(env, x, wall_face + 5.0, steps=800)
    assert not info["fell"]
    assert head[1] < wall_face - HEAD_RADIUS + 0.1  # against it at most, not through
    assert head[1] > wall_face - HEAD_RADIUS - 3.0  # it did walk up to it
    assert np.isfinite(head).all()
