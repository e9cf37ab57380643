import math
import subprocess
import sys

import numpy as np
import pytest

from aaai.config import load_config
from aaai.env import AnimalAIEnv
from aaai.levels.seeds import RESERVED_SEEDS, TRAIN_SEEDS, reserved_seeds
from aaai.train.curriculum import Curriculum


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
    # 20,000 draws: a seed drawn anywhere in the 2**32 would land among the reserved (a tenth of them) at
    # once; the borders, a hair either side, are tests/test_seed_ranges.py's
    curriculum = Curriculum(list(range(2)), list(range(11)), seed=5)
    seeds = np.array([curriculum.sample()[2] for _ in range(20_000)])
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
    code = "from aaai.levels.seeds import reserved_seeds; print(reserved_seeds(3, 7, 10))"
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
    assert math.isclose(config.curriculum.c, 0.05)


def test_heatmap_colours_each_cell_by_its_mean_return(tmp_path):
    import cv2

    from aaai.train.curriculum import CELL_PX, MARGIN_PX

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
        return image[y : y + 6, x : x + 6].reshape(-1, 3)

    image = picture({(0, 0): [-2.0, -2.0], (1, 1): [5.0, 5.0]})
    assert image is not None and image.std() > 20  # not a blank picture
    low, high, empty = cell(image, 0, 0), cell(image, 1, 1), cell(image, 0, 1)
    for square in (low, high, empty):
        assert (square == square[0]).all()  # each cell one flat colour
    assert np.abs(low[0].astype(int) - high[0].astype(int)).sum() > 100  # lowest and highest: far apart
    assert not (empty[0] == low[0]).all() and not (empty[0] == high[0]).all()  # no episode yet: neither
    swapped = picture({(0, 0): [5.0, 5.0], (1, 1): [-2.0, -2.0]})
    assert (cell(swapped, 0, 0) == high[0]).all() and (cell(swapped, 1, 1) == low[0]).all()


# --- the samplers ---------------------------------------------------------------------
SAMPLERS = ("paper", "uniform", "learnability", "plr")


def feed(curriculum, draws: int, rng_seed: int = 0) -> list[tuple[int, int, int]]:
    """Draws ``draws`` episodes and records a made-up result for each: returns and passes that
    differ by cell, so every sampler has something to prefer."""
    rng = np.random.default_rng(rng_seed)
    drawn = []
    for _ in range(draws):
        level, difficulty, seed = curriculum.sample()
        drawn.append((level, difficulty, seed))
        episode_return = float(rng.normal(level + difficulty, 0.5 + difficulty))
        curriculum.record(level, difficulty, episode_return, max_reward=2.0)
    return drawn


def test_paper_sampler_without_warmup_draws_exactly_as_the_z_score_formula():
    curriculum = Curriculum([0, 1], [0, 1], seed=11, sampler="paper", warmup=0)
    for value in (0.0, 4.0):
        curriculum.record(0, 1, value)
    curriculum.record(1, 0, 3.0)
    reference = np.random.default_rng(11)  # the paper's sampler: p = (z + c) / sum, z = std / |mean|
    weights = np.array([0.0, 2.0 / 2.0, 0.0, 0.0]) + 0.05
    from aaai.levels.seeds import training_seed

    for _ in range(50):
        index = int(reference.choice(4, p=weights / weights.sum()))
        expected = (*curriculum.cells[index], training_seed(reference))
        assert curriculum.sample() == expected


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_every_sampler_visits_every_cell_in_its_warmup(sampler):
    curriculum = Curriculum([0, 1], [0, 1, 2], sampler=sampler, warmup=3, seed=4)
    for value in (0.0, 10.0, 0.0, 10.0):  # a cell every sampler would favour at once, warm-up aside
        curriculum.record(0, 0, value, max_reward=10.0)
    drawn = feed(curriculum, 3 * len(curriculum.cells))
    counts = {cell: [d[:2] for d in drawn].count(cell) for cell in curriculum.cells}
    assert counts == {cell: 3 for cell in curriculum.cells}
    assert not curriculum.in_warmup()
    if sampler != "uniform":  # after the warm-up the sampler's own weights rule
        assert not np.allclose(curriculum.probabilities(), 1.0 / len(curriculum.cells))


def test_the_warmup_lasts_until_every_cell_has_its_results():
    curriculum = Curriculum([0], [0, 1], sampler="paper", warmup=1, seed=2)
    first = [curriculum.sample()[1] for _ in range(2)]  # two workers start: one episode in each cell
    assert sorted(first) == [0, 1]
    for value in (0.0, 10.0, 0.0, 10.0):
        curriculum.record(0, 0, value)  # cell 0 has results; cell 1's episode is still under way
    assert curriculum.in_warmup() and curriculum.probabilities() == pytest.approx([0.5, 0.5])
    curriculum.record(0, 1, 5.0)
    assert not curriculum.in_warmup() and curriculum.probabilities()[0] > 0.9


def test_no_sampler_without_warmup_visits_every_cell_first():
    curriculum = Curriculum([0, 1], [0, 1, 2], sampler="paper", warmup=0, seed=4)
    for value in (0.0, 10.0):
        curriculum.record(0, 0, value)
    drawn = [curriculum.sample()[:2] for _ in range(6)]
    assert len(set(drawn)) < 6  # what the warm-up is for


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_every_sampler_resumes_bit_for_bit(sampler):
    import json

    first = Curriculum([0, 1], [0, 2], sampler=sampler, warmup=2, seed=3)
    feed(first, 13)
    saved = json.loads(json.dumps(first.state_dict()))  # as state.json stores it
    second = Curriculum([0, 1], [0, 2], sampler=sampler, warmup=2, seed=99)
    second.load_state_dict(saved)
    assert second.state_dict() == saved
    for _ in range(30):
        assert np.array_equal(first.probabilities(), second.probabilities())
        a, b = first.sample(), second.sample()
        assert a == b
        first.record(a[0], a[1], float(a[2] % 7), max_reward=4.0)
        second.record(b[0], b[1], float(b[2] % 7), max_reward=4.0)
    assert first.state_dict() == second.state_dict()


def test_a_state_saved_before_the_samplers_still_resumes():
    old = Curriculum([0], [0, 1], seed=2)
    feed(old, 5)
    state = old.state_dict()
    for key in ("passes", "drawn", "last_drawn", "sampler", "warmup", "plr_temperature", "plr_staleness"):
        del state[key]
    resumed = Curriculum([0], [0, 1], seed=0)
    resumed.load_state_dict(state)
    assert [old.sample() for _ in range(10)] == [resumed.sample() for _ in range(10)]


def test_pass_rule_is_the_scoreboards_a_hair_either_side():
    from aaai.scoring import evaluation
    from aaai.train.curriculum import PASS_RATIO, episode_passed

    assert PASS_RATIO == evaluation.PASS_RATIO
    assert episode_passed(1.6, 2.0) and episode_passed(1.6 + 1e-9, 2.0)
    assert not episode_passed(1.6 - 1e-9, 2.0)
    assert not episode_passed(5.0, 0.0)  # no food to eat: never a pass (the scoreboard's ratio is nan)


def test_learnability_weights_match_hand_computed_values_either_side_of_the_pass_threshold():
    curriculum = Curriculum([0], [0, 1, 2, 3], sampler="learnability", warmup=0, c=0.05)
    curriculum.record(0, 0, 1.6 + 1e-9, max_reward=2.0)  # pass
    curriculum.record(0, 0, 0.0, max_reward=2.0)  # fail -> q = 1/2, q(1-q) = 1/4
    curriculum.record(0, 1, 1.6 - 1e-9, max_reward=2.0)  # a hair short: fail
    curriculum.record(0, 1, 0.0, max_reward=2.0)  # q = 0
    for _ in range(2):
        curriculum.record(0, 2, 2.0, max_reward=2.0)  # q = 1
    curriculum.record(0, 3, 1.6, max_reward=2.0)  # exactly the threshold passes
    for _ in range(3):
        curriculum.record(0, 3, -1.0, max_reward=2.0)  # q = 1/4, q(1-q) = 3/16
    assert curriculum.pass_rates() == pytest.approx([0.5, 0.0, 1.0, 0.25])
    weights = np.array([0.25, 0.0, 0.0, 3 / 16]) + 0.05
    assert curriculum.probabilities() == pytest.approx(weights / weights.sum(), abs=1e-12)
    curriculum.record(0, 1, 1.6 + 1e-9, max_reward=2.0)  # the hair the other way: q = 1/3
    weights[1] = 2 / 9 + 0.05
    assert curriculum.probabilities() == pytest.approx(weights / weights.sum(), abs=1e-12)
    short = Curriculum([0], [0], sampler="learnability", window=2, warmup=0)  # only the last window counts
    for value in (2.0, 0.0, 0.0):
        short.record(0, 0, value, max_reward=2.0)
    assert short.pass_rates()[0] == 0.0


@pytest.mark.parametrize("hair, first", [(+4e-9, 1), (-4e-9, 0)])
def test_plr_weights_match_hand_computed_ranks_and_staleness(hair, first):
    curriculum = Curriculum([0], [0, 1, 2], sampler="plr", warmup=1, plr_temperature=0.5, plr_staleness=0.2, seed=1)
    order = [curriculum.sample()[1] for _ in range(3)]  # the warm-up: each cell once, in this order
    assert sorted(order) == [0, 1, 2]
    age = np.zeros(3)
    for k, d in enumerate(order):
        age[d] = 3 - (k + 1)  # draws since the cell was last drawn: 2, 1, 0
    for value in (0.0, 1.0):
        curriculum.record(0, 0, value)  # positive value loss: mean(max(R - 0.5, 0)) = 0.25
    for value in (0.0, 1.0 + hair):
        curriculum.record(0, 1, value)  # 0.25 +- 1e-9: ranked first or second by a hair
    for value in (5.0, 5.0):
        curriculum.record(0, 2, value)  # 0: no surprise left
    assert curriculum.plr_scores() == pytest.approx([0.25, 0.25 + hair / 4, 0.0], abs=1e-15)
    ranks = np.array([2.0, 1.0, 3.0]) if first == 1 else np.array([1.0, 2.0, 3.0])
    h = (1.0 / ranks) ** 2  # temperature 0.5
    expected = 0.8 * h / h.sum() + 0.2 * age / age.sum()
    assert curriculum.probabilities() == pytest.approx(expected, abs=1e-12)
    tied = Curriculum([0], [0, 1], sampler="plr", warmup=0, plr_staleness=0.0, plr_temperature=1.0)
    for d in (0, 1):
        for value in (0.0, 1.0):
            tied.record(0, d, value)
    assert tied.probabilities() == pytest.approx([2 / 3, 1 / 3])  # a tie: ranked in cell order


def test_sampler_keys_in_the_config():
    from aaai.config import ConfigError

    config = load_config(sampler="plr", warmup=4, plr_temperature=0.1, plr_staleness=0.5, levels="0-1")
    curriculum = Curriculum.from_config(config)
    assert (curriculum.sampler, curriculum.warmup, curriculum.plr_temperature, curriculum.plr_staleness) == (
        "plr",
        4,
        0.1,
        0.5,
    )
    assert Curriculum.from_config(load_config(sampler="plr", mode="random")).sampler == "uniform"  # --random
    with pytest.raises(ConfigError, match="curriculum.sampler.*'best'.*paper, uniform, learnability, plr"):
        load_config(sampler="best")
    with pytest.raises(ConfigError, match="curriculum.warmup"):
        load_config(warmup=-1)


@pytest.mark.parametrize("sampler", ["paper", "learnability", "plr"])
def test_heatmap_shows_the_samplers_weights(tmp_path, sampler):
    import cv2

    from aaai.train.curriculum import CELL_PX, MARGIN_PX

    curriculum = Curriculum([0], [0, 1], sampler=sampler, warmup=0, plr_staleness=0.0)
    for value in (0.0, 2.0):
        curriculum.record(0, 0, value, max_reward=2.0)  # variable, half passed: favoured by all three
    for value in (1.0, 1.0):
        curriculum.record(0, 1, value, max_reward=2.0)
    p = curriculum.probabilities()
    assert p[0] > p[1]
    curriculum.write_heatmap(tmp_path / "c.png")
    image = cv2.imread(str(tmp_path / "c.png"))
    panel = MARGIN_PX + CELL_PX * 2 + 10
    assert image.shape[1] == 4 * panel  # mean return, episodes, the sampler's score, p
    y = MARGIN_PX + 4
    high, low = image[y, 3 * panel + MARGIN_PX + 4], image[y, 3 * panel + MARGIN_PX + CELL_PX + 4]
    assert np.abs(high.astype(int) - low.astype(int)).sum() > 100


def test_the_training_workers_tell_the_curriculum_whether_each_episode_passed():
    from aaai.train.vector import CurriculumVecEnv

    config = load_config(rays=False, max_steps=20, levels="0", difficulties="0")
    curriculum = Curriculum.from_config(load_config(config, sampler="learnability"))
    vec = CurriculumVecEnv(config, curriculum, num_envs=1, asynchronous=False)
    vec.reset()
    finished = []
    while len(finished) < 2:
        finished += vec.step(np.zeros((1, *vec.single_action_space.shape), np.float32))[4]
    vec.close()
    assert curriculum.episodes[(0, 0)] == 2
    from aaai.train.curriculum import episode_passed

    assert list(curriculum.passes[(0, 0)]) == [episode_passed(e.task_return, e.max_reward) for e in finished]
