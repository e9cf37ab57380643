"""The reference's planner (validate.path_costs) gives, bit for bit, the path costs of the step-by-step
Dijkstra search it replaced (kept here as the oracle): the committed scoreboards of the reference and of
the students it taught are scored again exactly only if every plan is the same float for float. Random
small grids (costs 0, fractions, huge, infinite, float32 as the reference's crowding is), and the real
grids of levels and of an imported Animal-AI arena, with the reference's own costs."""

import heapq
import math
import types

import numpy as np
import pytest
from conftest import AAI_AGENT, AAI_GOAL, AAI_WALL
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.levels import generate, validate
from aaai.levels.validate import FOOTPRINT_RADIUS, GRID, path_costs
from aaai.task.arena import load_arena
from aaai.task.reference import ReferenceController
from aaai.tools.animalai import import_animalai


def oracle(region: np.ndarray, goals: np.ndarray, cell_cost: np.ndarray | None = None) -> np.ndarray:
    """path_costs as it was: Dijkstra's algorithm in Python, one cell at a time (heapq)."""
    rows, cols = region.shape
    cost = np.ones(region.shape) if cell_cost is None else cell_cost
    inside = region.ravel().tolist()
    weight = cost.ravel().tolist()
    best = [math.inf] * (rows * cols)
    queue = []
    for index in np.flatnonzero(goals & region).tolist():
        best[index] = 0.0
        queue.append((0.0, index))
    heapq.heapify(queue)
    moves = [(dr, dc, GRID * math.hypot(dr, dc)) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    while queue:
        here, index = heapq.heappop(queue)
        if here > best[index]:
            continue
        row, col = divmod(index, cols)
        for dr, dc, length in moves:
            r, c = row + dr, col + dc
            if 0 <= r < rows and 0 <= c < cols:
                other = r * cols + c
                if inside[other]:
                    total = here + length * 0.5 * (weight[index] + weight[other])
                    if total < best[other]:
                        best[other] = total
                        heapq.heappush(queue, (total, other))
    return np.array(best).reshape(rows, cols)


def same(region, goals, cost=None) -> None:
    got, want = path_costs(region, goals, cost), oracle(region, goals, cost)
    assert got.dtype == np.float64 and got.shape == region.shape
    assert np.array_equal(got, want), f"{np.argwhere(got != want)[:5].tolist()} differ: {got[got != want][:5]}"


# --- random small grids -------------------------------------------------------------------
COSTS = {
    "float64": st.one_of(
        st.sampled_from([0.0, 1.0, 1e-300, 1e300, math.inf]),
        st.floats(0.0, 100.0),
        st.floats(1.0, 1.0 + 2**-40),  # sums that round
    ),
    "float32": st.one_of(st.sampled_from([0.0, 1.0, math.inf]), st.floats(0.0, 100.0, width=32)),
}


@st.composite
def grids(draw):
    shape = draw(st.tuples(st.integers(1, 9), st.integers(1, 9)))
    region = draw(hnp.arrays(bool, shape, elements=st.sampled_from([True, True, True, False])))
    goals = draw(hnp.arrays(bool, shape, elements=st.sampled_from([False, False, False, True])))
    kind = draw(st.sampled_from(["none", "float64", "float32"]))
    cost = None if kind == "none" else draw(hnp.arrays(kind, shape, elements=COSTS[kind]))
    return region, goals, cost


@settings(max_examples=150, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(grids())
def test_random_grids_are_planned_bit_for_bit_as_before(grid):
    same(*grid)


def test_no_goal_in_the_region_leaves_every_cell_unreachable():
    region = np.ones((4, 5), bool)
    region[1, 1] = False
    goals = np.zeros((4, 5), bool)
    for mark in (None, (1, 1)):  # no goal at all; a goal outside the region
        if mark:
            goals[mark] = True
        costs = path_costs(region, goals)
        assert costs.shape == (4, 5) and np.isposinf(costs).all()


def test_cells_of_cost_zero_are_still_walked_through():
    region = np.ones((1, 4), bool)
    goals = np.array([[True, False, False, False]])
    cost = np.array([[0.0, 0.0, 0.0, 2.0]])  # moves of cost 0, then (0 + 2) / 2 per GRID
    assert path_costs(region, goals, cost).ravel().tolist() == [0.0, 0.0, 0.0, GRID]
    same(region, goals, cost)


# --- the real grids -----------------------------------------------------------------------
def reference_map(spec):
    """The walking region and cell costs the reference plans with on ``spec`` (its ``_map``, on
    the grid it starts an episode with)."""
    state = types.SimpleNamespace(
        level=spec, grid=validate.blocked_grid(spec), footprint=FOOTPRINT_RADIUS, radius=HEAD_RADIUS
    )
    ReferenceController._map(state)
    return state.walk, state.crowding


def plans(spec, walk, crowding):
    """The reference's kinds of call: to the cells near each piece of food, with a berth of 50 round
    another piece (float32 costs, as its crowding is), and the search's from one cell (its start)."""
    rows, cols = walk.shape
    x = (np.arange(cols) + 0.5) * GRID - spec.arena_size[0] / 2
    y = (np.arange(rows) + 0.5) * GRID - spec.arena_size[1] / 2
    foods = spec.foods
    for food in foods:
        goals = walk & (np.hypot(x[None, :] - food.position[0], y[:, None] - food.position[1]) <= 2.0 + food.size[0])
        cost = crowding.copy()
        other = foods[-1]
        cost[np.hypot(x[None, :] - other.position[0], y[:, None] - other.position[1]) < 6.0] += 50.0
        yield goals, cost
    here = np.zeros(walk.shape, bool)
    here[validate.cell(spec, spec.agent.x, spec.agent.y, walk.shape)] = True
    yield here, crowding


@pytest.mark.parametrize("level, difficulty, seed", [(1, 10, 3), (6, 5, 0), (9, 10, 1), (11, 10, 2)])
def test_the_levels_grids_are_planned_bit_for_bit_as_before(level, difficulty, seed):
    spec = generate(level, difficulty, seed)
    walk, crowding = reference_map(spec)
    assert crowding.dtype == np.float32 and walk.any()
    for goals, cost in plans(spec, walk, crowding):
        assert (goals & walk).any()
        same(walk, goals, cost)
    same(walk, here_and_there(walk))  # the default cost, two goals


def here_and_there(walk):
    goals = np.zeros(walk.shape, bool)
    cells = np.argwhere(walk)
    goals[tuple(cells[0])] = goals[tuple(cells[-1])] = True
    return goals


def wall_arena(folder):
    """An Animal-AI arena (40 x 40, imported at scale 5: 200 x 200 units, 400 x 400 cells) with a wall
    across most of it and the food behind, imported into ``folder``."""
    items = AAI_AGENT.format(x=20, z=5, r=0) + AAI_WALL.format(x=16, z=20, sx=30, sz=1) + AAI_GOAL.format(x=20, z=35)
    source = folder / "src"
    source.mkdir()
    (source / "wall.yaml").write_text("!ArenaConfig\narenas:\n  0: !Arena\n    t: 250\n    items:\n" + items)
    (result,) = import_animalai(source, folder / "out", echo=lambda _: None)
    assert not result.problem
    return load_arena(folder / "out" / "wall.yaml")


def test_an_imported_arena_is_planned_bit_for_bit_as_before(tmp_path):
    spec = wall_arena(tmp_path)
    walk, crowding = reference_map(spec)
    assert walk.shape == (400, 400)
    goals, cost = next(plans(spec, walk, crowding))
    costs = path_costs(walk, goals, cost)
    assert np.isfinite(costs).sum() > 100_000  # the way round the wall is planned
    assert np.array_equal(costs, oracle(walk, goals, cost))
