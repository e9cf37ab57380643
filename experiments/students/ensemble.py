"""A student made of several saved points of one DAgger run: each acts, the actions are averaged.

`aaai eval --policy experiments.students.ensemble:policy --config RUN/config.yaml` scores it, with
the models listed in the environment variable AAAI_ENSEMBLE (comma-separated .zip files, all of one
run, so of one environment). Each member acts as `aaai eval` makes it act (float64, its action on
the 2^-20 grid); their mean is put on the grid again.

    AAAI_ENSEMBLE=RUN/checkpoints/step_A/model.zip,RUN/final/model.zip \\
      aaai eval --policy experiments.students.ensemble:policy --config RUN/config.yaml -k 4
"""

from __future__ import annotations

import os

import numpy as np

from aaai.scoring.policies import on_grid, resolve


class Ensemble:
    def __init__(self, members: list) -> None:
        self.members = members

    def reset(self, seed: int | None = None) -> None:
        for member in self.members:
            if hasattr(member, "reset"):
                member.reset(seed)

    def __call__(self, observation) -> np.ndarray:
        actions = [np.asarray(member(observation), np.float64) for member in self.members]
        return on_grid(np.mean(actions, axis=0))


def policy(env) -> Ensemble:
    paths = [path for path in os.environ.get("AAAI_ENSEMBLE", "").split(",") if path]
    if len(paths) < 2:
        raise ValueError(f"AAAI_ENSEMBLE: got {paths!r}; allowed: two or more model .zip files, comma-separated")
    return Ensemble([resolve(path).build(env) for path in paths])
