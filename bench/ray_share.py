"""Where the rays' time goes, per level: rayTestBatch's share of `Rays.observe`.

Times every `Rays.observe` call of an environment with the default rays (joints + rays), and the
`rayTestBatch` call inside it, over random-action steps; the levels are taken in turn each round
(the order rotated), and each level's share is the median over rounds (min..max). Writes
bench/ray_share.csv and bench/ray_share.md.

    nice -n 10 .venv/bin/python bench/ray_share.py --rounds 3 --steps 1000
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time
from pathlib import Path

import numpy as np
import pybullet

import aaai.sim.sensors as sensors
from aaai.env import AnimalAIEnv
from aaai.levels import all_levels

OUT = Path(__file__).resolve().parent


class Timed:
    """pybullet with rayTestBatch timed (everything else passed through)."""

    def __init__(self):
        self.seconds = 0.0

    def __getattr__(self, name):
        return getattr(pybullet, name)

    def rayTestBatch(self, *args, **kwargs):
        start = time.perf_counter()
        hits = pybullet.rayTestBatch(*args, **kwargs)
        self.seconds += time.perf_counter() - start
        return hits


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=1000)
    args = parser.parse_args()
    timed = Timed()
    sensors.p = timed
    observe = sensors.Rays.observe
    spent = {"observe": 0.0}

    def timed_observe(self, *a, **k):
        start = time.perf_counter()
        result = observe(self, *a, **k)
        spent["observe"] += time.perf_counter() - start
        return result

    sensors.Rays.observe = timed_observe
    levels = sorted(all_levels())
    labels = {i: all_levels()[i].label for i in levels}
    envs = {level: AnimalAIEnv(level=level, difficulty=5) for level in levels}
    rows = []
    load_before = os.getloadavg()
    for round_ in range(args.rounds):
        order = levels[round_ % len(levels) :] + levels[: round_ % len(levels)]
        for level in order:
            env = envs[level]
            rng = np.random.default_rng(round_)
            env.reset(seed=1000 + round_)
            timed.seconds, spent["observe"] = 0.0, 0.0
            for _ in range(args.steps):
                _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
                if terminated or truncated:
                    env.reset(seed=int(rng.integers(1 << 30)))
            rows.append(
                {
                    "round": round_,
                    "level": level,
                    "observe_us": round(spent["observe"] / args.steps * 1e6, 1),
                    "raytest_us": round(timed.seconds / args.steps * 1e6, 1),
                }
            )
    load_after = os.getloadavg()
    with (OUT / "ray_share.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# rayTestBatch's share of Rays.observe (default rays, difficulty 5, random actions)",
        "",
        f"{args.rounds} rounds x {args.steps} steps per level, levels alternated; load average"
        f" {[round(v, 1) for v in load_before]} before, {[round(v, 1) for v in load_after]} after."
        " Medians over rounds (min..max).",
        "",
        "| level | Rays.observe us/step | rayTestBatch us/step | rayTestBatch share |",
        "|---|---:|---:|---:|",
    ]
    for level in levels:
        mine = [r for r in rows if r["level"] == level]
        shares = [r["raytest_us"] / r["observe_us"] for r in mine if r["observe_us"]]
        lines.append(
            f"| {labels[level]} | {statistics.median(r['observe_us'] for r in mine):.0f}"
            f" | {statistics.median(r['raytest_us'] for r in mine):.0f}"
            f" | {statistics.median(shares):.0%} ({min(shares):.0%}..{max(shares):.0%}) |"
        )
    (OUT / "ray_share.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
