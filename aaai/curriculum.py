"""The curriculum sampler: which (level, difficulty) cell, and which seed, the next episode gets.

Each active cell keeps the returns of its last ``window`` episodes. With mu and sigma their mean
and standard deviation (or, as in the original build, their variance),
z = sigma / (|mu| + 1e-7), and z = 0 with fewer than two returns. A cell is drawn with
p = (z + c) / sum(z + c), recomputed before every episode; ``mode="random"`` draws uniformly.
"""
from __future__ import annotations

from collections import deque
from pathlib import Path

import cv2
import numpy as np

from aaai.files import atomic_path
from aaai.levels import get_level
from aaai.seeds import training_seed

EPSILON = 1e-7
Cell = tuple[int, int]


class Curriculum:
    def __init__(self, levels: list[int], difficulties: list[int], mode: str = "curriculum",
                 window: int = 10, c: float = 0.05, spread: str = "std", seed: int = 0):
        if mode not in ("curriculum", "random"):
            raise ValueError(f"curriculum mode: got {mode!r}; allowed: curriculum, random")
        if spread not in ("std", "variance"):
            raise ValueError(f"curriculum spread: got {spread!r}; allowed: std, variance")
        self.cells: list[Cell] = [(level, d) for level in levels for d in difficulties]
        if not self.cells:
            raise ValueError("the curriculum has no active (level, difficulty) cell")
        self.mode, self.window, self.c, self.spread = mode, window, c, spread
        self.returns: dict[Cell, deque] = {cell: deque(maxlen=window) for cell in self.cells}
        self.episodes: dict[Cell, int] = {cell: 0 for cell in self.cells}
        self.rng = np.random.default_rng(seed)

    @classmethod
    def from_config(cls, config: dict) -> "Curriculum":
        cur = config["curriculum"]
        return cls(cur["levels"], cur["difficulties"], cur["mode"], cur["window"], cur["c"], cur["spread"],
                   seed=config["train"]["seed"])

    def z_scores(self) -> np.ndarray:
        z = np.zeros(len(self.cells))
        for i, cell in enumerate(self.cells):
            values = np.array(self.returns[cell], dtype=np.float64)
            if len(values) < 2:
                continue
            spread = values.std() if self.spread == "std" else values.var()
            z[i] = spread / (abs(values.mean()) + EPSILON)
        return z

    def probabilities(self) -> np.ndarray:
        if self.mode == "random":
            return np.full(len(self.cells), 1.0 / len(self.cells))
        weights = self.z_scores() + self.c
        return weights / weights.sum()

    def sample(self) -> tuple[int, int, int]:
        """The next episode's (level, difficulty, training seed)."""
        index = int(self.rng.choice(len(self.cells), p=self.probabilities()))
        level, difficulty = self.cells[index]
        return level, difficulty, training_seed(self.rng)

    def record(self, level: int, difficulty: int, episode_return: float) -> None:
        cell = (level, difficulty)
        if cell not in self.returns:
            raise KeyError(f"cell {cell} is not active; active: {self.cells}")
        self.returns[cell].append(float(episode_return))
        self.episodes[cell] += 1

    def mean_returns(self) -> np.ndarray:
        return np.array([np.mean(self.returns[cell]) if self.returns[cell] else np.nan for cell in self.cells])

    # --- checkpoints ----------------------------------------------------------------
    def state_dict(self) -> dict:
        return {
            "cells": [list(cell) for cell in self.cells],
            "mode": self.mode, "window": self.window, "c": self.c, "spread": self.spread,
            "returns": [list(self.returns[cell]) for cell in self.cells],
            "episodes": [self.episodes[cell] for cell in self.cells],
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict) -> None:
        cells = [tuple(cell) for cell in state["cells"]]
        if cells != self.cells:
            raise ValueError(f"the saved curriculum has cells {cells}, this one {self.cells}")
        for cell, returns, count in zip(cells, state["returns"], state["episodes"]):
            self.returns[cell] = deque(returns, maxlen=self.window)
            self.episodes[cell] = count
        self.rng.bit_generator.state = state["rng"]

    # --- picture --------------------------------------------------------------------
    def write_heatmap(self, path: str | Path) -> None:
        """A PNG of mean return, z and p per cell (rows: levels, columns: difficulties)."""
        panels = [("mean return", self.mean_returns()), ("z", self.z_scores()), ("p", self.probabilities())]
        images = [heatmap_panel(title, values, self.cells) for title, values in panels]
        picture = np.concatenate(images, axis=1)
        with atomic_path(path) as temporary:
            if not cv2.imwrite(str(temporary), picture):
                raise OSError(f"OpenCV could not write {path}")


CELL_PX, MARGIN_PX = 44, 40


def heatmap_panel(title: str, values: np.ndarray, cells: list[Cell], limits: tuple[float, float] | None = None,
                  text: list[str] | None = None) -> np.ndarray:
    """One picture of a value per (level, difficulty) cell: rows levels, columns difficulties,
    coloured from ``limits`` (default: the values' own range), each cell labelled with its
    value (or with ``text``)."""
    levels = sorted({level for level, _ in cells})
    difficulties = sorted({d for _, d in cells})
    height = MARGIN_PX + CELL_PX * len(levels) + 10
    width = MARGIN_PX + CELL_PX * len(difficulties) + 10
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
        cv2.putText(image, label, (x + 2, y + CELL_PX // 2 + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.33, (255, 255, 255), 1,
                    cv2.LINE_AA)
    for row, level in enumerate(levels):
        cv2.putText(image, get_level(level).label, (4, MARGIN_PX + row * CELL_PX + CELL_PX // 2 + 4),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    for col, d in enumerate(difficulties):
        cv2.putText(image, f"d{d}", (MARGIN_PX + col * CELL_PX + 8, MARGIN_PX - 6),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return image
