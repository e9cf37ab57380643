"""The curriculum's rules a hair either side: its defaults, its refusals, each sampler's weights at
their edges, what a checkpoint holds, and the heatmap's picture pixel for pixel.

``python -m tests.test_curriculum_rules`` rewrites the heatmap fixture (after a deliberate change
to the picture: say why in the commit)."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from aaai.config import load_config
from aaai.train.curriculum import CELL_PX, MARGIN_PX, Curriculum, heatmap_panel, positive_value_loss, rank_weights

FIXTURE = Path(__file__).parent / "fixtures" / "curriculum_heatmap.png"


def test_the_defaults_are_the_papers_sampler():
    curriculum = Curriculum([0], [0, 1])
    assert (curriculum.mode, curriculum.sampler, curriculum.window, curriculum.c, curriculum.spread) == (
        "curriculum",
        "paper",
        10,
        0.05,
        "std",
    )
    assert (curriculum.warmup, curriculum.plr_temperature, curriculum.plr_staleness) == (0, 0.3, 0.3)
    assert curriculum.sample() == Curriculum([0], [0, 1], seed=0).sample()  # seed 0 by default
    assert not curriculum.in_warmup()


@pytest.mark.parametrize(
    "keywords, message",
    [
        ({"mode": "best"}, "curriculum mode: got 'best'; allowed: curriculum, random"),
        ({"spread": "range"}, "curriculum spread: got 'range'; allowed: std, variance"),
        ({"sampler": "best"}, "curriculum sampler: got 'best'; allowed: paper, uniform, learnability, plr"),
        ({"warmup": -1}, "curriculum warmup: got -1; allowed: 0 or more episodes per cell"),
    ],
)
def test_bad_settings_are_refused_naming_the_setting_the_value_and_what_is_allowed(keywords, message):
    with pytest.raises(ValueError) as error:
        Curriculum([0], [0], **keywords)
    assert str(error.value) == message


def test_no_cell_and_an_inactive_cell_are_refused():
    with pytest.raises(ValueError) as error:
        Curriculum([], [0])
    assert str(error.value) == "the curriculum has no active (level, difficulty) cell"
    with pytest.raises(KeyError) as error:
        Curriculum([0], [0, 1]).record(2, 0, 1.0)
    assert error.value.args[0] == "cell (2, 0) is not active; active: [(0, 0), (0, 1)]"


def test_every_config_key_reaches_the_curriculum():
    config = load_config(levels="0-1", difficulties="0,2", window=4, c=0.2, spread="variance", seed=7)
    config = config.replace(warmup=2, plr_temperature=0.7, plr_staleness=0.4, sampler="learnability")
    curriculum = Curriculum.from_config(config)
    assert curriculum.cells == [(0, 0), (0, 2), (1, 0), (1, 2)]
    assert (curriculum.mode, curriculum.window, curriculum.c, curriculum.spread, curriculum.sampler) == (
        "curriculum",
        4,
        0.2,
        "variance",
        "learnability",
    )
    assert (curriculum.warmup, curriculum.plr_temperature, curriculum.plr_staleness) == (2, 0.7, 0.4)
    assert curriculum.returns[(0, 0)].maxlen == 4 and curriculum.passes[(0, 0)].maxlen == 4
    same = Curriculum([0, 1], [0, 2], seed=7, sampler="learnability", warmup=2)
    assert [curriculum.sample() for _ in range(4)] == [same.sample() for _ in range(4)]  # the train seed
    config = config.replace(mode="random")
    assert Curriculum.from_config(config).mode == "random"


def test_a_warmup_of_one_holds_until_each_cell_has_one_result_then_lets_go():
    curriculum = Curriculum([0], [0, 1], warmup=1)
    assert curriculum.in_warmup()
    curriculum.record(0, 0, 1.0)
    assert curriculum.in_warmup()
    curriculum.record(0, 1, 1.0)
    assert not curriculum.in_warmup()  # exactly ``warmup`` results: done
    # in the warm-up, only the cells drawn least may come next, all alike
    warm = Curriculum([0], [0, 1, 2], warmup=1, seed=5)
    first = warm.sample()[1]
    expected = np.full(3, 0.5)
    expected[first] = 0.0
    assert np.array_equal(warm.probabilities(), expected)


def test_z_needs_two_returns_and_treats_one_as_none():
    curriculum = Curriculum([0], [0, 1, 2], c=0.05)
    curriculum.record(0, 0, 4.0)  # one return: z = 0 (and no division by one value's spread)
    for value in (1.0, 3.0):
        curriculum.record(0, 1, value)  # two returns: std 1, mean 2
    for value in (-1.0, -3.0):
        curriculum.record(0, 2, value)  # |mean|: the sign does not matter
    assert np.array_equal(curriculum.z_scores(), [0.0, 1.0 / (2.0 + 1e-7), 1.0 / (2.0 + 1e-7)])


def test_pass_rates_and_mean_returns_are_nan_until_a_cell_has_results():
    curriculum = Curriculum([0], [0, 1])
    curriculum.record(0, 0, 1.0)  # no max reward: a return but no pass or failure
    assert np.isnan(curriculum.pass_rates()).all()
    assert np.array_equal(curriculum.learnability(), [0.0, 0.0])
    rates = curriculum.mean_returns()
    assert rates[0] == 1.0 and np.isnan(rates[1])
    curriculum.record(0, 0, 3.0, max_reward=3.0)
    assert curriculum.pass_rates()[0] == 1.0 and curriculum.mean_returns()[0] == 2.0


def test_learnability_is_q_times_one_minus_q():
    curriculum = Curriculum([0], [0], sampler="learnability")
    for value in (2.0, 0.0, 0.0, 0.0):
        curriculum.record(0, 0, value, max_reward=2.0)
    assert curriculum.learnability()[0] == 0.25 * 0.75


def test_positive_value_loss_and_rank_weights_at_their_edges():
    assert positive_value_loss([]) == 0.0
    assert positive_value_loss([3.0]) == 0.0
    assert positive_value_loss([2.0, 2.0, 2.0]) == 0.0
    assert positive_value_loss([0.0, 4.0]) == 1.0  # mean 2: (0 + 2) / 2
    assert positive_value_loss([0.0, 0.0, 3.0]) == pytest.approx(2.0 / 3.0)  # mean 1: (0 + 0 + 2) / 3
    assert positive_value_loss([-3.0, 0.0, 0.0]) == pytest.approx(2.0 / 3.0)  # mean -1: (0 + 1 + 1) / 3
    many = np.zeros(40)
    many[5] = 1.0  # one cell first, the 39 tied after it in cell order (however many cells there are)
    expected = np.empty(40)
    expected[5], expected[[i for i in range(40) if i != 5]] = 1.0, 1.0 / np.arange(2, 41)
    assert rank_weights(many, 1.0) == pytest.approx(expected / expected.sum())
    weights = rank_weights(np.array([1.0, 3.0, 2.0]), 1.0)  # ranks 3, 1, 2
    assert weights == pytest.approx(np.array([1 / 3, 1.0, 1 / 2]) / (11 / 6))
    assert rank_weights(np.array([0.0, 0.0, 0.0]), 0.5) == pytest.approx(np.array([1.0, 1 / 4, 1 / 9]) / (49 / 36))


def test_staleness_is_uniform_before_any_draw_then_the_draws_since_each_cell_was_last_drawn():
    curriculum = Curriculum([0], [0, 1, 2, 3], sampler="plr", seed=3)
    assert np.array_equal(curriculum.staleness(), [0.25] * 4)
    picks = []
    for _ in range(3):
        picks.append(curriculum.sample()[1])
        assert curriculum.last_drawn[picks[-1]] == len(picks)
    assert curriculum.drawn.sum() == 3
    age = 3.0 - curriculum.last_drawn
    assert np.array_equal(curriculum.staleness(), age / age.sum())


def test_plr_without_staleness_is_its_rank_weights_and_with_full_staleness_its_ages():
    curriculum = Curriculum([0], [0, 1], sampler="plr", plr_staleness=0.0, plr_temperature=1.0)
    for value in (0.0, 4.0):
        curriculum.record(0, 1, value)
    assert curriculum.probabilities() == pytest.approx([1 / 3, 2 / 3])
    stale = Curriculum([0], [0, 1], sampler="plr", plr_staleness=1.0, seed=2)
    drawn = stale.sample()[1]
    expected = np.zeros(2)
    expected[1 - drawn] = 1.0
    assert stale.probabilities() == pytest.approx(expected)


def test_the_uniform_sampler_ignores_every_statistic():
    curriculum = Curriculum([0], [0, 1, 2, 3], sampler="uniform")
    for value in (0.0, 10.0):
        curriculum.record(0, 0, value, max_reward=10.0)
    assert np.array_equal(curriculum.probabilities(), [0.25] * 4)
    assert curriculum.scores()[0] == "episodes"
    assert np.array_equal(curriculum.scores()[1], [2.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("sampler, name", [("paper", "z"), ("learnability", "q(1-q)"), ("plr", "PLR score")])
def test_each_sampler_names_its_own_score(sampler, name):
    curriculum = Curriculum([0], [0, 1], sampler=sampler)
    for value in (0.0, 2.0):
        curriculum.record(0, 0, value, max_reward=2.0)
    title, score = curriculum.scores()
    own = {"paper": curriculum.z_scores, "learnability": curriculum.learnability, "plr": curriculum.plr_scores}
    assert title == name and np.array_equal(score, own[sampler]())


def test_a_checkpoint_holds_every_setting_and_statistic_by_name():
    curriculum = Curriculum([0], [0, 1], sampler="plr", warmup=1, window=3, c=0.1, seed=4)
    level, difficulty, _ = curriculum.sample()
    curriculum.record(level, difficulty, 2.0, max_reward=2.0)
    state = curriculum.state_dict()
    assert list(state) == [
        "cells",
        "mode",
        "sampler",
        "window",
        "c",
        "spread",
        "warmup",
        "plr_temperature",
        "plr_staleness",
        "returns",
        "passes",
        "episodes",
        "drawn",
        "last_drawn",
        "rng",
    ]
    first = [0, 0]
    first[difficulty] = 1
    assert state["cells"] == [[0, 0], [0, 1]]
    assert (state["mode"], state["sampler"], state["window"], state["c"], state["spread"]) == (
        "curriculum",
        "plr",
        3,
        0.1,
        "std",
    )
    assert (state["warmup"], state["plr_temperature"], state["plr_staleness"]) == (1, 0.3, 0.3)
    assert state["returns"][difficulty] == [2.0] and state["passes"][difficulty] == [True]
    assert state["episodes"] == first and state["drawn"] == first and state["last_drawn"] == first


def test_an_old_checkpoint_takes_its_draws_from_its_episodes_and_no_passes():
    old = Curriculum([0], [0, 1], window=3)
    old.record(0, 0, 1.0, max_reward=1.0)
    old.record(0, 0, 1.0, max_reward=1.0)
    state = old.state_dict()
    for key in ("passes", "drawn", "last_drawn"):
        del state[key]
    resumed = Curriculum([0], [0, 1], window=3)
    resumed.load_state_dict(state)
    assert resumed.drawn.tolist() == [2, 0] and resumed.drawn.dtype == np.int64
    assert resumed.last_drawn.tolist() == [0, 0] and resumed.last_drawn.dtype == np.int64
    assert [list(resumed.passes[cell]) for cell in resumed.cells] == [[], []]
    assert resumed.returns[(0, 0)].maxlen == 3 and resumed.passes[(0, 0)].maxlen == 3
    state["passes"] = [[1, 0, 1, 1], []]
    resumed.load_state_dict(state)
    assert list(resumed.passes[(0, 0)]) == [False, True, True]  # the window's last three, as booleans
    with pytest.raises(ValueError) as error:
        Curriculum([0], [0, 2]).load_state_dict(state)
    assert str(error.value) == "the saved curriculum has cells [(0, 0), (0, 1)], this one [(0, 0), (0, 2)]"


def test_a_checkpoint_keeps_the_episodes_still_under_way():
    curriculum = Curriculum([0], [0, 1], sampler="plr", seed=6)
    first = curriculum.sample()  # under way: drawn, not yet recorded
    second = curriculum.sample()
    curriculum.record(*second[:2], 1.0)
    resumed = Curriculum([0], [0, 1], sampler="plr")
    resumed.load_state_dict(curriculum.state_dict())
    assert resumed.drawn.tolist() == curriculum.drawn.tolist() and sum(resumed.episodes.values()) == 1
    assert resumed.last_drawn.tolist() == curriculum.last_drawn.tolist()
    assert first[:2] != second[:2] or resumed.drawn.max() == 2
    assert np.array_equal(resumed.probabilities(), curriculum.probabilities())


def _heatmap(tmp_path) -> np.ndarray:
    curriculum = Curriculum([0, 1], [0, 1], sampler="learnability", warmup=1, seed=1)
    for value in (0.0, 2.0, 2.0):
        curriculum.record(0, 0, value, max_reward=2.0)
    curriculum.record(1, 1, -1.0, max_reward=2.0)
    path = Path(tmp_path) / "heatmap.png"
    curriculum.write_heatmap(path)
    return cv2.imread(str(path))


def test_the_heatmap_is_drawn_pixel_for_pixel_as_before(tmp_path):
    image = _heatmap(tmp_path)
    panel = MARGIN_PX + CELL_PX * 2 + 10
    # mean return, episodes, q(1-q), and p, whose title "p (learnability, warm-up)" widens its panel
    assert image.shape[0] == panel and 4 * panel < image.shape[1] < 5 * panel
    expected = cv2.imread(str(FIXTURE))
    differ = np.argwhere((image != expected).any(axis=2))
    assert differ.size == 0, f"{len(differ)} pixels differ, the first at (y, x) {differ[0].tolist()}"


@pytest.mark.parametrize("cells", [[(0, 0)], [(0, 0), (0, 1)], [(0, d) for d in range(11)]])
def test_a_panels_title_is_drawn_whole_however_few_its_cells(cells):
    title = "p (learnability, warm-up)"
    panel = heatmap_panel(title, np.zeros(len(cells)), cells)
    band = (panel[:22] < 200).any(axis=2)  # the title's row: dark pixels are its letters
    columns = np.flatnonzero(band.any(axis=0))
    (width, _), _ = cv2.getTextSize(title, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
    assert columns[-1] < panel.shape[1] - 5  # white to the panel's edge after the last letter
    assert columns[-1] - columns[0] >= width - 4  # and the letters span the whole title
    assert panel.shape[1] >= MARGIN_PX + CELL_PX * len(cells) + 10  # the cells keep their room


def test_a_panel_without_finite_values_or_spread_still_draws_each_cell(tmp_path):
    cells = [(0, 0), (0, 1)]
    grey = heatmap_panel("t", np.array([np.nan, np.nan]), cells)
    y, x = MARGIN_PX + 2, MARGIN_PX + 2
    assert grey[y, x].tolist() == [220, 220, 220] and grey[y, x + CELL_PX].tolist() == [220, 220, 220]
    flat = heatmap_panel("t", np.array([0.5, 0.5]), cells)  # no spread: both the lowest colour
    lowest = cv2.applyColorMap(np.array([[0]], np.uint8), cv2.COLORMAP_VIRIDIS)[0, 0].tolist()
    assert flat[y, x].tolist() == lowest and flat[y, x + CELL_PX].tolist() == lowest
    fixed = heatmap_panel("t", np.array([0.5, 2.0]), cells, limits=(0.0, 1.0))  # clipped to the limits
    half = cv2.applyColorMap(np.array([[127]], np.uint8), cv2.COLORMAP_VIRIDIS)[0, 0].tolist()
    top = cv2.applyColorMap(np.array([[255]], np.uint8), cv2.COLORMAP_VIRIDIS)[0, 0].tolist()
    assert fixed[y, x].tolist() == half and fixed[y, x + CELL_PX].tolist() == top
    below = heatmap_panel("t", np.array([-1.0, 1.0]), cells, limits=(0.0, 1.0))
    assert below[y, x].tolist() == lowest
    # the square's last pixel is CELL_PX - 2 from its corner; the gap between squares is white
    assert fixed[y, x + CELL_PX - 2 - 2].tolist() == half and fixed[y, x + CELL_PX - 1 - 2].tolist() == [255] * 3


if __name__ == "__main__":
    cv2.imwrite(str(FIXTURE), _heatmap(FIXTURE.parent))
    (FIXTURE.parent / "heatmap.png").unlink()
    print(f"wrote {FIXTURE}")
