"""The curriculum: which (level, difficulty) cell, and which seed, the next episode gets.

One class, :class:`Curriculum`, draws cells; ``sampler`` says how it weights them:

* ``paper``: the paper's z-score sampler. Each active cell keeps the returns of its last
  ``window`` episodes. With mu and sigma their mean and standard deviation (or, as in the
  original build, their variance), z = sigma / (|mu| + 1e-7), and z = 0 with fewer than two
  returns; p = (z + c) / sum(z + c).
* ``uniform``: every active cell alike (``mode="random"`` is another name for it).
* ``learnability``: p = (q(1 - q) + c) / sum(q(1 - q) + c), where q is the pass rate of the
  cell's last ``window`` episodes (an episode passes when its task return reaches PASS_RATIO of
  its max reward, as on the scoreboard); a cell with no recorded pass or failure has q = 0.
* ``plr``: Prioritized Level Replay (Jiang et al., 2021) over cells.
  p = (1 - rho) P_S + rho P_C. P_S is rank-based: h = 1 / rank(score), P_S = h^(1/beta) / sum;
  rank 1 is the highest score, ties ranked in cell order. P_C is staleness: (draws now - draws
  when the cell was last drawn), normalised (uniform when all are 0). The score is a
  return-based proxy of PLR's positive value loss: the mean of max(R - V, 0) over the cell's last
  ``window`` returns R, with V their mean (a Monte-Carlo value estimate of the cell's start
  state, so R - V is the advantage with gamma = lambda = 1); 0 with fewer than two returns.
  It needs no value function, so it works with every learner (PPO, RLlib, random).

Warm-up (every sampler): until every active cell has finished ``warmup`` episodes, the next cell
is drawn uniformly among the cells drawn least (episodes under way count as drawn). So the first
``warmup`` x cells draws visit every cell ``warmup`` times, and no statistic is trusted before
every cell has ``warmup`` results. With ``warmup=0``, ``paper`` is the paper's sampler bit for
bit. Probabilities are recomputed before every episode.
"""

from __future__ import annotations

from collections import deque
from pathlib import Path

import cv2
import numpy as np

from aaai.config import Config
from aaai.files import atomic_path
from aaai.levels import get_level
from aaai.levels.seeds import training_seed

EPSILON = 1e-7
PASS_RATIO = 0.8  # an episode passes at task return >= PASS_RATIO x max reward (aaai.scoring.evaluation uses the same)
SAMPLERS = ("paper", "uniform", "learnability", "plr")
Cell = tuple[int, int]


def episode_passed(task_return: float, max_reward: float) -> bool:
    """The scoreboard's rule: passed (or succeeded) when return / max reward >= PASS_RATIO."""
    return bool(max_reward > 0 and task_return / max_reward >= PASS_RATIO)


def positive_value_loss(values) -> float:
    """PLR's score from returns alone: mean of max(R - mean(R), 0); 0 for fewer than two or equal returns."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2 or values.max() == values.min():
        return 0.0
    return float(np.maximum(values - values.mean(), 0.0).mean())


def rank_weights(scores: np.ndarray, temperature: float) -> np.ndarray:
    """PLR's rank prioritisation: (1 / rank)^(1 / temperature), normalised; rank 1 = highest score,
    ties in index order."""
    order = np.argsort(-scores, kind="stable")
    ranks = np.empty(len(scores))
    ranks[order] = np.arange(1, len(scores) + 1)
    weights = (1.0 / ranks) ** (1.0 / temperature)
    return weights / weights.sum()


class Curriculum:
    def __init__(
        self,
        levels: list[int],
        difficulties: list[int],
        mode: str = "curriculum",
        window: int = 10,
        c: float = 0.05,
        spread: str = "std",
        seed: int = 0,
        sampler: str = "paper",
        warmup: int = 0,
        plr_temperature: float = 0.3,
        plr_staleness: float = 0.3,
    ):
        if mode not in ("curriculum", "random"):
            raise ValueError(f"curriculum mode: got {mode!r}; allowed: curriculum, random")
        if spread not in ("std", "variance"):
            raise ValueError(f"curriculum spread: got {spread!r}; allowed: std, variance")
        if sampler not in SAMPLERS:
            raise ValueError(f"curriculum sampler: got {sampler!r}; allowed: {', '.join(SAMPLERS)}")
        if warmup < 0:
            raise ValueError(f"curriculum warmup: got {warmup!r}; allowed: 0 or more episodes per cell")
        self.cells: list[Cell] = [(level, d) for level in levels for d in difficulties]
        if not self.cells:
            raise ValueError("the curriculum has no active (level, difficulty) cell")
        self.mode, self.window, self.c, self.spread = mode, window, c, spread
        self.sampler = "uniform" if mode == "random" else sampler
        self.warmup, self.plr_temperature, self.plr_staleness = warmup, plr_temperature, plr_staleness
        self.returns: dict[Cell, deque] = {cell: deque(maxlen=window) for cell in self.cells}
        self.passes: dict[Cell, deque] = {cell: deque(maxlen=window) for cell in self.cells}
        self.episodes: dict[Cell, int] = {cell: 0 for cell in self.cells}
        self.drawn = np.zeros(len(self.cells), dtype=np.int64)  # episodes assigned to each cell
        self.last_drawn = np.zeros(len(self.cells), dtype=np.int64)  # draws done when each cell was last drawn
        self.rng = np.random.default_rng(seed)

    @classmethod
    def from_config(cls, config: Config) -> "Curriculum":
        cur = config.curriculum
        return cls(
            list(cur.levels),
            list(cur.difficulties),
            cur.mode,
            cur.window,
            cur.c,
            cur.spread,
            seed=config.train.seed,
            sampler=cur.sampler,
            warmup=cur.warmup,
            plr_temperature=cur.plr_temperature,
            plr_staleness=cur.plr_staleness,
        )

    # --- statistics -----------------------------------------------------------------
    def z_scores(self) -> np.ndarray:
        z = np.zeros(len(self.cells))
        for i, cell in enumerate(self.cells):
            values = np.array(self.returns[cell], dtype=np.float64)
            if len(values) < 2:
                continue
            spread = values.std() if self.spread == "std" else values.var()
            z[i] = spread / (abs(values.mean()) + EPSILON)
        return z

    def pass_rates(self) -> np.ndarray:
        """Each cell's pass rate over its last ``window`` episodes (nan before its first)."""
        return np.array([np.mean(self.passes[cell]) if self.passes[cell] else np.nan for cell in self.cells])

    def learnability(self) -> np.ndarray:
        q = np.nan_to_num(self.pass_rates(), nan=0.0)
        return q * (1.0 - q)

    def plr_scores(self) -> np.ndarray:
        return np.array([positive_value_loss(self.returns[cell]) for cell in self.cells])

    def staleness(self) -> np.ndarray:
        """PLR's P_C: draws since each cell was last drawn, normalised (uniform when all are 0)."""
        age = (int(self.drawn.sum()) - self.last_drawn).astype(np.float64)
        total = age.sum()
        return age / total if total > 0 else np.full(len(self.cells), 1.0 / len(self.cells))

    def scores(self) -> tuple[str, np.ndarray]:
        """The sampler's own score per cell, with its name (the heatmap's third panel)."""
        if self.sampler == "paper":
            return "z", self.z_scores()
        if self.sampler == "learnability":
            return "q(1-q)", self.learnability()
        if self.sampler == "plr":
            return "PLR score", self.plr_scores()
        return "episodes", np.array([float(self.episodes[cell]) for cell in self.cells])

    def in_warmup(self) -> bool:
        """Has some active cell finished fewer than ``warmup`` episodes?"""
        return min(self.episodes.values()) < self.warmup

    def probabilities(self) -> np.ndarray:
        """The chance of each cell for the next episode."""
        n = len(self.cells)
        if self.in_warmup():
            least = (self.drawn == self.drawn.min()).astype(np.float64)
            return least / least.sum()
        if self.sampler == "uniform":
            return np.full(n, 1.0 / n)
        if self.sampler == "paper":
            weights = self.z_scores() + self.c
        elif self.sampler == "learnability":
            weights = self.learnability() + self.c
        else:
            rho = self.plr_staleness
            return (1.0 - rho) * rank_weights(self.plr_scores(), self.plr_temperature) + rho * self.staleness()
        return weights / weights.sum()

    def sample(self) -> tuple[int, int, int]:
        """The next episode's (level, difficulty, training seed)."""
        index = int(self.rng.choice(len(self.cells), p=self.probabilities()))
        self.drawn[index] += 1
        self.last_drawn[index] = int(self.drawn.sum())
        level, difficulty = self.cells[index]
        return level, difficulty, training_seed(self.rng)

    def record(self, level: int, difficulty: int, episode_return: float, max_reward: float | None = None) -> None:
        """A finished episode's task return (and, given its max reward, whether it passed)."""
        cell = (level, difficulty)
        if cell not in self.returns:
            raise KeyError(f"cell {cell} is not active; active: {self.cells}")
        self.returns[cell].append(float(episode_return))
        if max_reward is not None:
            self.passes[cell].append(episode_passed(episode_return, max_reward))
        self.episodes[cell] += 1

    def mean_returns(self) -> np.ndarray:
        return np.array([np.mean(self.returns[cell]) if self.returns[cell] else np.nan for cell in self.cells])

    # --- checkpoints ----------------------------------------------------------------
    def state_dict(self) -> dict:
        return {
            "cells": [list(cell) for cell in self.cells],
            "mode": self.mode,
            "sampler": self.sampler,
            "window": self.window,
            "c": self.c,
            "spread": self.spread,
            "warmup": self.warmup,
            "plr_temperature": self.plr_temperature,
            "plr_staleness": self.plr_staleness,
            "returns": [list(self.returns[cell]) for cell in self.cells],
            "passes": [list(self.passes[cell]) for cell in self.cells],
            "episodes": [self.episodes[cell] for cell in self.cells],
            "drawn": self.drawn.tolist(),
            "last_drawn": self.last_drawn.tolist(),
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict) -> None:
        """Continues from ``state``; a state saved before passes and draws were kept starts them
        from its episode counts."""
        cells = [tuple(cell) for cell in state["cells"]]
        if cells != self.cells:
            raise ValueError(f"the saved curriculum has cells {cells}, this one {self.cells}")
        passes = state.get("passes", [[] for _ in cells])
        for cell, returns, passed, count in zip(cells, state["returns"], passes, state["episodes"]):
            self.returns[cell] = deque(returns, maxlen=self.window)
            self.passes[cell] = deque((bool(p) for p in passed), maxlen=self.window)
            self.episodes[cell] = count
        self.drawn = np.array(state.get("drawn", state["episodes"]), dtype=np.int64)
        self.last_drawn = np.array(state.get("last_drawn", [0] * len(cells)), dtype=np.int64)
        self.rng.bit_generator.state = state["rng"]

    # --- picture --------------------------------------------------------------------
    def write_heatmap(self, path: str | Path) -> None:
        """A PNG per cell (rows: levels, columns: difficulties) of mean return, episodes, the
        sampler's own score (z, q(1-q), PLR score) and p, the chance of the next draw."""
        episodes = np.array([float(self.episodes[cell]) for cell in self.cells])
        score_title, score = self.scores()
        panels = [("mean return", self.mean_returns(), None), ("episodes", episodes, [f"{int(v)}" for v in episodes])]
        if score_title != "episodes":
            panels.append((score_title, score, None))
        panels.append((f"p ({self.sampler}{', warm-up' if self.in_warmup() else ''})", self.probabilities(), None))
        images = [heatmap_panel(title, values, self.cells, text=text) for title, values, text in panels]
        picture = np.concatenate(images, axis=1)
        with atomic_path(path) as temporary:
            if not cv2.imwrite(str(temporary), picture):
                raise OSError(f"OpenCV could not write {path}")


CELL_PX, MARGIN_PX = 44, 40


def heatmap_panel(
    title: str,
    values: np.ndarray,
    cells: list[Cell],
    limits: tuple[float, float] | None = None,
    text: list[str] | None = None,
) -> np.ndarray:
    """One picture of a value per (level, difficulty) cell: rows levels, columns difficulties,
    coloured from ``limits`` (default: the values' own range), each cell labelled with its
    value (or with ``text``)."""
    levels = sorted({level for level, _ in cells})
    difficulties = sorted({d for _, d in cells})
    height = MARGIN_PX + CELL_PX * len(levels) + 10
    (title_width, _), _ = cv2.getTextSize(title, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
    width = max(MARGIN_PX + CELL_PX * len(difficulties), 4 + title_width) + 10  # the title whole, however few cells
    image = np.full((height, width, 3), 255, np.uint8)
    finite = values[np.isfinite(values)]
    low, high = limits or ((finite.min(), finite.max()) if finite.size else (0.0, 1.0))
    scale = (high - low) or 1.0
    cv2.putText(image, title, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for index, ((level, d), value) in enumerate(zip(cells, values)):
        row, col = levels.index(level), difficulties.index(d)
        y, x = MARGIN_PX + row * CELL_PX, MARGIN_PX + col * CELL_PX
        if np.isfinite(value):
            shade = np.uint8(255 * min(max((value - low) / scale, 0.0), 1.0))
            colour = cv2.applyColorMap(np.array([[shade]], np.uint8), cv2.COLORMAP_VIRIDIS)[0, 0].tolist()
            label = f"{value:.2f}" if text is None else text[index]
        else:
            colour, label = [220, 220, 220], "-"
        cv2.rectangle(image, (x, y), (x + CELL_PX - 2, y + CELL_PX - 2), colour, -1)
        cv2.putText(
            image, label, (x + 2, y + CELL_PX // 2 + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.33, (255, 255, 255), 1, cv2.LINE_AA
        )
    for row, level in enumerate(levels):
        cv2.putText(
            image,
            get_level(level).label,
            (4, MARGIN_PX + row * CELL_PX + CELL_PX // 2 + 4),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
    for col, d in enumerate(difficulties):
        cv2.putText(
            image,
            f"d{d}",
            (MARGIN_PX + col * CELL_PX + 8, MARGIN_PX - 6),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
    return image
