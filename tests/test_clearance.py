"""The clearance map (validate.clearance_map) is a pure function of the grid: the exact Euclidean distance
to the nearest blocked cell, its float32 square root correctly rounded, the same bytes whatever the grid's
memory layout and wherever the arrays lie in memory. The reference plans on it (its crowding costs) and
level validation thresholds it, so a last bit that moved with the heap gave another route from one
process to another (L3 difficulty 0 seed 1372987030: 1227 or 1470 steps)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aaai.levels import generate, validate
from aaai.levels.validate import GRID

BIG = 1 << 40


def exact_squares(free: np.ndarray) -> np.ndarray:
    """The squared distance (cells) from each cell to the nearest cell that is not free, by brute force:
    the least (r - r')**2 down each column, then the least of that plus (c - c')**2 along each row."""
    rows, cols = free.shape
    r, c = np.arange(rows), np.arange(cols)
    down = np.where(~free[None, :, :], (r[:, None] - r[None, :])[:, :, None] ** 2, BIG).min(axis=1)
    return (down[:, None, :] + ((c[:, None] - c[None, :]) ** 2)[None, :, :]).min(axis=2)


def exact_clearance(grid: np.ndarray) -> np.ndarray:
    """clearance_map by brute force: the float32 square root (correctly rounded) of the exact squared distance."""
    padded = np.pad(grid, 1, constant_values=1)
    return np.sqrt(exact_squares(padded == 0).astype(np.float32))[1:-1, 1:-1] * GRID


SPEC = generate(3, 0, 1372987030)  # a level whose reference route moved with the clearance's last bits
GRID_L3 = validate.blocked_grid(SPEC)


def layouts(grid: np.ndarray):
    """The same grid in 20 layouts: as it is, Fortran order, copies at 16 byte offsets, a strided view, bool."""
    yield grid
    yield np.asfortranarray(grid)
    for offset in range(16):
        buffer = np.zeros(grid.size + 64, np.uint8)
        start = (-buffer.ctypes.data % 64) + offset
        placed = buffer[start : start + grid.size].reshape(grid.shape)
        placed[:] = grid
        yield placed
    spread = np.zeros((grid.shape[0] * 2, grid.shape[1] * 3), np.uint8)
    spread[::2, ::3] = grid
    yield spread[::2, ::3]
    yield grid.astype(bool)


def test_the_clearance_of_a_level_is_the_exact_distance_in_float32():
    clearance = validate.clearance_map(SPEC, GRID_L3)
    assert clearance.dtype == np.float32 and clearance.shape == GRID_L3.shape
    want = exact_clearance(GRID_L3)
    assert np.array_equal(clearance, want), f"{int((clearance != want).sum())} cells differ"
    assert np.array_equal(validate.clearance_map(SPEC), want)  # the grid made from the spec


def test_the_clearance_is_the_same_bytes_for_any_layout_and_heap():
    want = validate.clearance_map(SPEC, GRID_L3).tobytes()
    kept = []  # allocations of many sizes kept alive, so each result lands elsewhere on the heap
    for k, grid in enumerate(layouts(GRID_L3)):
        kept += [np.empty(4 * k + 8, np.uint8), np.empty(GRID_L3.size * 4 + 4 * k, np.uint8)]
        assert validate.clearance_map(SPEC, grid).tobytes() == want, f"layout {k}"


@settings(max_examples=60, deadline=None, derandomize=True)
@given(hnp.arrays(bool, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.booleans()))
def test_distances_are_exact_on_any_small_grid(free):
    got = validate.distances(free)
    assert got.dtype == np.float32 and got.shape == free.shape
    if free.all():  # nothing blocked: no distance is finite
        assert np.isinf(got).all()
    else:
        assert np.array_equal(got, np.sqrt(exact_squares(free).astype(np.float32)))
