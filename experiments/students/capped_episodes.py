"""How many of a DAgger run's episodes its episode cap stopped before their end, by level.

    python experiments/students/capped_episodes.py RUN [RUN ...] --cap 600 [--last 572] > TABLE.md

Reads each run folder's ``episodes.csv`` (one row per DAgger episode: its level and length in
decisions). An episode of ``--cap`` decisions or more was stopped by the cap, unless its level's time
limit is no longer (L8: 3,000 control steps, 600 decisions of 0.1 s), where the time limit ends it
("-": the cap cannot stop it). L6 and L7 play a random other level with its own time limit. Passed:
eaten at least 80 % of the level's food reward. ``--last N``: each run's last N episodes only (the
rounds a resumed run added); for a run without that cap the column counts the episodes played to it or past.
"""

from __future__ import annotations

import argparse
import csv
from collections import defaultdict
from pathlib import Path

from aaai.levels import all_levels
from aaai.scoring.episodes import PASS_RATIO


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--cap", type=int, default=600)
    parser.add_argument("--decision", type=float, default=0.1, help="seconds a decision is held")
    parser.add_argument("--last", type=int, default=0, help="each run's last N episodes only (0: all)")
    args = parser.parse_args()
    levels = all_levels()
    print(
        "| level | time limit, decisions (d0 to d10) | "
        + " | ".join(f"`{run.name}`: episodes, {args.cap} decisions or more, passed" for run in args.runs)
        + " |"
    )
    print("|---|---|" + "---|" * len(args.runs))
    counts = []
    for run in args.runs:
        by_level: dict[int, list[int]] = defaultdict(lambda: [0, 0, 0])
        with open(run / "episodes.csv", newline="") as handle:
            rows = list(csv.DictReader(handle))
            for row in rows[-args.last :] if args.last else rows:
                cell = by_level[int(row["level"])]
                cell[0] += 1
                cell[1] += int(row["length"]) >= args.cap
                maximum = float(row["max_reward"])
                cell[2] += maximum > 0 and float(row["task_return"]) / maximum >= PASS_RATIO
        counts.append(by_level)
    for level_id in sorted(counts[0]):
        level = levels[level_id]
        limits = [round(level.time_limit_at(d) / args.decision) for d in (0, 10)]
        binds = level.wraps or max(limits) > args.cap
        cells = [
            f"{n}, {f'{capped} ({100 * capped / n:.0f} %)' if binds else '-'}, {passed} ({100 * passed / n:.0f} %)"
            for n, capped, passed in (c[level_id] for c in counts)
        ]
        limit = "the played level's" if level.wraps else f"{limits[0]:,} to {limits[1]:,}"
        print(f"| {level.label} {level.title} | {limit} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
