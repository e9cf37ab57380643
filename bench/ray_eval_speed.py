"""Eval episodes/s: the Ray backend (local Ray, N workers) against the local backend, same policy and seeds.

    python bench/ray_eval_speed.py                      # 20 L0 d0 episodes of the random policy, 2 workers
    python bench/ray_eval_speed.py --episodes 40 --workers 2 --policy reference

Prints both rates and their ratio: once counting Ray's start and stop (what `aaai eval --backend ray`
costs), once for the episodes alone (Ray already up, its workers' first imports included).
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path


def main(episodes: int = 20, workers: int = 2, policy: str = "random", level: int = 0, difficulty: int = 0) -> dict:
    from aaai.scoring.distributed import RaySession, evaluate_on_ray
    from aaai.scoring.evaluation import Cell, evaluate
    from aaai.scoring.policies import resolve

    name, policy = policy, resolve(policy)
    config = policy.config()  # a run's own senses, else the defaults
    cells = [Cell(level, difficulty, list(range(1000, 1000 + episodes)))]
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        started = time.perf_counter()
        local_rows = evaluate(policy, cells, folder / "local.csv", config)
        local = time.perf_counter() - started
        steps = sum(int(row["steps"]) for row in local_rows)

        started = time.perf_counter()
        evaluate_on_ray(policy, cells, folder / "ray_total.csv", config, workers=workers)
        ray_total = time.perf_counter() - started

        with RaySession(None, workers):
            started = time.perf_counter()
            evaluate_on_ray(policy, cells, folder / "ray_episodes.csv", config, workers=workers)
            ray_episodes = time.perf_counter() - started
        same = all(
            _table(folder / name) == _table(folder / "local.csv") for name in ("ray_total.csv", "ray_episodes.csv")
        )
    result = {
        "episodes": episodes,
        "steps": steps,
        "workers": workers,
        "policy": name,
        "local_s": local,
        "ray_total_s": ray_total,
        "ray_episodes_s": ray_episodes,
        "same_rows": same,
    }
    print(f"{episodes} episodes of L{level} d{difficulty} ({steps} steps), policy {policy}")
    print(f"local backend:              {local:7.2f} s  {episodes / local:6.2f} episodes/s")
    print(
        f"ray, {workers} workers, start+stop: {ray_total:7.2f} s  {episodes / ray_total:6.2f} episodes/s  "
        f"ratio {local / ray_total:.2f}x"
    )
    print(
        f"ray, {workers} workers, episodes:   {ray_episodes:7.2f} s  {episodes / ray_episodes:6.2f} episodes/s  "
        f"ratio {local / ray_episodes:.2f}x"
    )
    print(f"scoreboards equal, timing aside: {same}")
    return result


def _table(path: Path) -> list[list[str]]:
    with open(path, newline="") as handle:
        return [row[:-1] for row in csv.reader(handle)]


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--policy", default="random")
    parser.add_argument("--level", type=int, default=0)
    parser.add_argument("--difficulty", type=int, default=0)
    args = parser.parse_args()
    main(args.episodes, args.workers, args.policy, args.level, args.difficulty)
