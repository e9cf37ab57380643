"""Worker processes x environments per worker against the same environments in one process.

For each K of ``--per-worker``, the training vector env (the shipped training config, random
actions) with K environments in-process, K in one worker process, 2K in 2 worker processes (K
each) and 2K in 2K processes (one each), alternated over ``--rounds`` rounds
(aaai.tools.workers_bench). Each K's figures go to bench/workers/K<k>.json as soon as they are
measured; a K already there is skipped (``--again`` measures it anew), so an interrupted run
resumes. bench/workers.md gathers the tables.

    nice -n 0 .venv/bin/python bench/workers_speed.py --per-worker 1,2,4,8 --rounds 5
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from aaai.files import write_atomic
from aaai.tools.workers_bench import markdown, workers_rates

OUT = Path(__file__).resolve().parent


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--per-worker", default="4", help="environments per worker process, comma-separated")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=500, help="vector steps per runner and round")
    parser.add_argument("--joints-only", action="store_true", help="no rays (the issue's L0 joints figures)")
    parser.add_argument("--again", action="store_true")
    args = parser.parse_args()
    folder = OUT / "workers"
    folder.mkdir(exist_ok=True)
    config = {"sensors": {"rays": False}} if args.joints_only else None
    suffix = "_joints" if args.joints_only else ""
    for k in [int(x) for x in args.per_worker.split(",")]:
        path = folder / f"K{k}{suffix}.json"
        if path.exists() and not args.again:
            print(f"K={k}: {path.name} is there (--again measures it anew)")
            continue
        print(f"K={k}: load {os.getloadavg()} ...", flush=True)
        results = workers_rates(k, args.steps, args.rounds, config)
        results["rounds"] = args.rounds
        write_atomic(path, json.dumps(results, indent=2) + "\n")
        print(markdown(results), flush=True)
    parts = []
    for path in sorted(
        folder.glob("K*.json"), key=lambda p: (p.stem.endswith("joints"), int(p.stem[1:].split("_")[0]))
    ):
        results = json.loads(path.read_text())
        senses = "with rays" if "rays" in results["config"]["sensors"] else "no rays"
        parts.append(f"## K = {results['config']['per_worker']}, {senses} ({path.name}, {results['rounds']} rounds)\n")
        parts.append(markdown(results))
    write_atomic(OUT / "workers.md", "# Worker processes x environments per worker\n\n" + "\n".join(parts))


if __name__ == "__main__":
    main()
