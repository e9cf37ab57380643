import math
import subprocess
import sys

import numpy as np
import pytest

from aaai.config import load_config
from aaai.curriculum import Curriculum
from aaai.env import AnimalAIEnv
from aaai.seeds import RESERVED_SEEDS, TRAIN_SEEDS, reserved_seeds


def test_z_and_p_match_hand_computed_values():
    curriculum = Curriculum([0, 1], [0], c=0.05)
    for value in (1.0, 3.0):  # mean 2, population std 1 -> z = 0.5
        curriculum.record(0, 0, value)
    curriculum.record(1, 0, 5.0)  # one return: z = 0
    assert curriculum.z_scores() == pytest.approx([0.5, 0.0])
    assert curriculum.probabilities() == pytest.approx([0.55 / 0.6, 0.05 / 0.6])


def test_variance_switch_uses_the_original_builds_spread():
    curriculum = Curriculum([0], [0, 1], spread="variance", c=0.05)
    for value in (-1.0, -3.0, -5.0):  # mean -3, variance 8/3 -> z = (8/3) / 3
        curriculum.record(0, 0, value)
    assert curriculum.z_scores()[0] == pytest.approx((8 / 3) / 3)
    weights = np.array([8 / 9 + 0.05, 0.05])
    assert curriculum.probabilities() == pytest.approx(weights / weights.sum())


def test_zero_mean_gives_a_large_but_finite_z():
    curriculum = Curriculum([0], [0])
    curriculum.record(0, 0, -1.0)
    curriculum.record(0, 0, 1.0)
    assert curriculum.z_scores()[0] == pytest.approx(1.0 / 1e-7)


def test_each_cell_keeps_only_its_last_window_returns():
    curriculum = Curriculum([0], [0], window=10)
    for value in range(25):
        curriculum.record(0, 0, float(value))
    assert list(curriculum.returns[(0, 0)]) == [float(v) for v in range(15, 25)]
    assert curriculum.episodes[(0, 0)] == 25


def test_random_mode_is_uniform_and_the_curriculum_favours_variable_cells():
    uniform = Curriculum([0, 1], [0, 1], mode="random")
    uniform.record(0, 0, 1.0)
    uniform.record(0, 0, 9.0)
    assert uniform.probabilities() == pytest.approx([0.25] * 4)
    draws = [uniform.sample()[:2] for _ in range(4000)]
    assert min(draws.count(cell) for cell in uniform.cells) > 850
    curriculum = Curriculum([0, 1], [0], seed=1)
    for value in (0.0, 10.0):
        curriculum.record(0, 0, value)
    for value in (5.0, 5.0):
        curriculum.record(1, 0, value)
    draws = [curriculum.sample()[:2] for _ in range(2000)]
    assert draws.count((0, 0)) > 0.9 * len(draws)


def test_state_round_trip_continues_the_same_draws():
    first = Curriculum([0, 1], [0, 2], seed=3)
    for i in range(7):
        level, difficulty, _ = first.sample()
        first.record(level, difficulty, float(i % 3))
    second = Curriculum([0, 1], [0, 2], seed=99)
    second.load_state_dict(first.state_dict())
    assert [first.sample() for _ in range(20)] == [second.sample() for _ in range(20)]
    with pytest.raises(ValueError, match="cells"):
        Curriculum([0], [0]).load_state_dict(first.state_dict())


def test_heatmap_is_written(tmp_path):
    curriculum = Curriculum([0, 1], [0, 1, 2])
    curriculum.record(0, 1, 2.0)
    curriculum.write_heatmap(tmp_path / "curriculum.png")
    import cv2

    image = cv2.imread(str(tmp_path / "curriculum.png"))
    assert image is not None and image.shape[1] > image.shape[0]


def test_training_never_draws_a_reserved_seed():
    curriculum = Curriculum(list(range(2)), list(range(11)), seed=5)
    seeds = np.array([curriculum.sample()[2] for _ in range(200_000)])
    assert seeds.min() >= TRAIN_SEEDS.start and seeds.max() < TRAIN_SEEDS.stop
    assert not np.any((seeds >= RESERVED_SEEDS.start) & (seeds < RESERVED_SEEDS.stop))
    env = AnimalAIEnv(rays=False)  # unseeded resets draw training seeds too
    env.reset(seed=1)
    assert all(env.reset()[1]["seed"] < TRAIN_SEEDS.stop for _ in range(200))
    env.close()


def test_reserved_seeds_are_fixed_distinct_and_in_range():
    seeds = reserved_seeds(3, 7, 50)
    assert len(set(seeds)) == 50 and all(s in RESERVED_SEEDS for s in seeds)
    assert reserved_seeds(3, 7, 10) == seeds[:10]  # a longer list extends a shorter one
    assert reserved_seeds(3, 6, 10) != seeds[:10]
    code = "from aaai.seeds import reserved_seeds; print(reserved_seeds(3, 7, 10))"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert other.stdout.strip() == str(seeds[:10])


def test_curriculum_config_is_validated():
    config = load_config(levels="0-1", difficulties="0,3-4", mode="random")
    curriculum = Curriculum.from_config(config)
    assert curriculum.cells == [(0, 0), (0, 3), (0, 4), (1, 0), (1, 3), (1, 4)]
    assert curriculum.mode == "random"
    from aaai.config import ConfigError

    with pytest.raises(ConfigError, match="curriculum.difficulties.*'0-11'.*0 to 10"):
        load_config(difficulties="0-11")
    assert math.isclose(config["curriculum"]["c"], 0.05)


def test_heatmap_colours_each_cell_by_its_mean_return(tmp_path):
    import cv2

    from aaai.curriculum import CELL_PX, MARGIN_PX

    def picture(returns: dict) -> np.ndarray:
        curriculum = Curriculum([0, 1], [0, 1])
        for (level, difficulty), values in returns.items():
            for value in values:
                curriculum.record(level, difficulty, value)
        path = tmp_path / f"heatmap_{len(list(tmp_path.iterdir()))}.png"
        curriculum.write_heatmap(path)
        return cv2.imread(str(path))

    def cell(image, row, col):  # a corner of the cell's square in the first panel (mean return), clear of its label
        y, x = MARGIN_PX + row * CELL_PX + 4, MARGIN_PX + col * CELL_PX + 4
        return image[y:y + 6, x:x + 6].reshape(-1, 3)

    image = picture({(0, 0): [-2.0, -2.0], (1, 1): [5.0, 5.0]})
    assert image is not None and image.std() > 20  # not a blank picture
    low, high, empty = cell(image, 0, 0), cell(image, 1, 1), cell(image, 0, 1)
    for square in (low, high, empty):
        assert (square == square[0]).all()  # each cell one flat colour
    assert np.abs(low[0].astype(int) - high[0].astype(int)).sum() > 100  # lowest and highest: far apart
    assert not (empty[0] == low[0]).all() and not (empty[0] == high[0]).all()  # no episode yet: neither
    swapped = picture({(0, 0): [5.0, 5.0], (1, 1): [-2.0, -2.0]})
    assert (cell(swapped, 0, 0) == high[0]).all() and (cell(swapped, 1, 1) == low[0]).all()
