"""validate.path_costs: the reference's planner. Costs are path lengths in units on the grid
(straight moves GRID, diagonal GRID x sqrt 2), weighted by the mean cost of the two cells a move
joins, only through the region, and infinite where no path leads to a goal."""

import math

import numpy as np
import pytest

from aaai.levels.validate import GRID, path_costs


def grid(rows: int, cols: int) -> np.ndarray:
    return np.ones((rows, cols), bool)


def test_straight_and_diagonal_moves_cost_their_length():
    goals = np.zeros((5, 5), bool)
    goals[2, 2] = True
    costs = path_costs(grid(5, 5), goals)
    assert costs[2, 2] == 0.0
    assert costs[2, 4] == pytest.approx(2 * GRID)  # two straight moves
    assert costs[0, 0] == pytest.approx(2 * GRID * math.sqrt(2))  # two diagonal moves
    assert costs[0, 3] == pytest.approx(GRID * (math.sqrt(2) + 1))  # one of each, the cheapest mix


def test_the_nearest_goal_counts():
    goals = np.zeros((1, 7), bool)
    goals[0, 0] = goals[0, 6] = True
    costs = path_costs(grid(1, 7), goals)
    assert costs.ravel().tolist() == pytest.approx([GRID * n for n in (0, 1, 2, 3, 2, 1, 0)])


def test_a_path_goes_round_what_is_outside_the_region_and_none_leads_through_a_closed_wall():
    region = grid(3, 5)
    region[0:2, 2] = False  # a wall from the top, open at the bottom row
    goals = np.zeros((3, 5), bool)
    goals[0, 4] = True
    costs = path_costs(region, goals)
    assert costs[0, 0] == pytest.approx(4 * GRID * math.sqrt(2))  # diagonally down, under the wall's end, up
    assert costs[0, 2] == math.inf and costs[1, 2] == math.inf  # outside the region
    region[2, 2] = False  # closed
    closed = path_costs(region, goals)
    assert np.isinf(closed[:, :2]).all() and np.isfinite(closed[:, 3:]).all()


def test_a_goal_outside_the_region_is_no_goal():
    goals = np.zeros((3, 3), bool)
    goals[1, 1] = True
    region = grid(3, 3)
    region[1, 1] = False
    assert np.isinf(path_costs(region, goals)).all()


def test_a_move_costs_the_mean_cell_cost_of_the_cells_it_joins():
    goals = np.zeros((1, 3), bool)
    goals[0, 0] = True
    weights = np.array([[1.0, 3.0, 5.0]])
    costs = path_costs(grid(1, 3), goals, weights)
    assert costs.ravel().tolist() == pytest.approx([0.0, 2.0 * GRID, 6.0 * GRID])  # (1+3)/2, then (3+5)/2
