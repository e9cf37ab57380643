"""Timing by alternation: runners called in turn over rounds, per-round ratios, medians and spreads.

The benchmark's rows (:mod:`aaai.tools.bench`, :mod:`aaai.tools.workers_bench`) are built from
these: each runner returns a rate per call; a ratio is taken within a round, between figures
measured a moment apart, and reported as the median over the rounds with its spread (min..max).
"""

from __future__ import annotations

import os
from typing import Any, Callable

import numpy as np

WARM_UP = 50  # untimed steps of each runner before the first round


def alternate(runners: dict[str, Callable[[], float]], rounds: int) -> dict[str, list[float]]:
    """Calls every runner once per round, in an order rotated by one each round; each call returns
    a rate. Returns each runner's rates, one per round."""
    names = list(runners)
    rates: dict[str, list[float]] = {name: [] for name in names}
    for r in range(rounds):
        shift = r % len(names)
        for name in names[shift:] + names[:shift]:
            rates[name].append(float(runners[name]()))
    return rates


def summary(values: list[float]) -> dict:
    """The median of per-round values and their spread."""
    return {
        "median": float(np.median(values)),
        "min": float(min(values)),
        "max": float(max(values)),
        "rounds": [float(v) for v in values],
    }


def spread_text(values: list[float], digits: int = 1) -> str:
    """Per-round values as 'median (min..max)'."""
    figure = summary(values)
    return f"{figure['median']:.{digits}f} ({figure['min']:.{digits}f}..{figure['max']:.{digits}f})"


def per_round(numerator: list[float], denominator: list[float], minus_one: bool = False) -> list[float]:
    """Round by round ratios (numerator / denominator, less one for an overhead)."""
    return [a / b - (1.0 if minus_one else 0.0) for a, b in zip(numerator, denominator)]


def load() -> list[float]:
    """The machine's load average over 1, 5 and 15 minutes."""
    return [round(value, 2) for value in os.getloadavg()]


def write_report(path, lines: list[str]) -> None:
    """A bench's markdown: ``lines`` and the load average when written, to ``path`` and to stdout."""
    lines = [*lines, "", f"Load average when written: {' '.join(f'{v:.2f}' for v in load())}.", ""]
    path.write_text("\n".join(lines))
    print("\n".join(lines))


def run_group(runners: dict[str, Any], rounds: int) -> tuple[dict[str, list[float]], dict]:
    """Warms every runner up (``runner(WARM_UP)``), alternates them over ``rounds``, closes them
    (``runner.close()``); returns each one's rates (one a round) and the load before and after."""
    before = load()
    try:
        for runner in runners.values():
            runner(WARM_UP)
        rates = alternate(runners, rounds)
    finally:
        for runner in runners.values():
            runner.close()
    return rates, {"before": before, "after": load()}
