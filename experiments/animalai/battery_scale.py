"""How far the battery lies from the levels in scale, and the pass rates by how far the food starts.

    python experiments/animalai/battery_scale.py BATTERY baselines/battery/reference.csv \
        baselines/battery/student_food_memory.csv ...

BATTERY is `aaai import-animalai`'s --out (the folder the scoreboards were scored on). Prints two
Markdown tables: the arenas' sizes, the good food's sizes and the start-to-food distances, of the
battery's files (seed 0) and of the levels (every level at difficulties 0, 5 and 10, reserved seeds
1000 and 1001, a sample); and each scoreboard's seed-0 passes by the distance from the agent's start
to the nearest good food (within the student's ray length, 50; 50 to 100; beyond 100).
"""

from __future__ import annotations

import math
import statistics
import sys
from pathlib import Path

from aaai.levels import all_levels, generate
from aaai.spec import LevelSpec
from aaai.task.arena import parse_arena
from aaai.tools.baselines import passed
from aaai.train.limbs import read_rows

BUCKETS = (  # (low, high]: the first takes in food right at the start
    (-math.inf, 50.0, "up to 50 (student_food_memory's ray length; student_search's is 15)"),
    (50.0, 100.0, "50 to 100"),
    (100.0, math.inf, "beyond 100"),
)


def _nearest(spec: LevelSpec) -> float:
    """From the agent's start to the nearest piece of good food (``spec.foods``: not bad food)."""
    start = (spec.agent.x, spec.agent.y)
    return min((math.dist(start, food.position[:2]) for food in spec.foods), default=math.nan)


def _describe(name: str, specs: list[LevelSpec]) -> str:
    widths = sorted({s.arena_size[0] for s in specs})
    sizes = sorted({food.size[0] for s in specs for food in s.foods})
    near = [d for d in map(_nearest, specs) if not math.isnan(d)]
    return (
        f"| {name} | {len(specs)} | {widths[0]:g} to {widths[-1]:g} | {sizes[0]:g} to {sizes[-1]:g} | "
        f"{statistics.median(near):.0f} | {max(near):.0f} |"
    )


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__)
        return 2
    battery, boards = Path(argv[0]), [Path(a) for a in argv[1:]]
    specs = {path.name: parse_arena(path, 0)[0] for path in sorted(battery.glob("*.yaml"))}
    distance = {name: _nearest(spec) for name, spec in specs.items()}
    levels = [generate(level, d, seed) for level in all_levels() for d in (0, 5, 10) for seed in (1000, 1001)]
    print("| specs | how many | arena across | good food across | start to nearest good food: median | farthest |")
    print("|---|---:|---:|---:|---:|---:|")
    print(_describe("the levels (a sample)", levels))
    print(_describe("the battery's valid files, seed 0", list(specs.values())))
    print()
    print("| start to nearest good food | files | " + " | ".join(b.stem for b in boards) + " |")
    print("|---|---:|" + "---:|" * len(boards))
    passes = [{row["arena"] for row in read_rows(b) if row["seed"] == "0" and passed(row)} for b in boards]
    for low, high, label in BUCKETS:
        inside = {name for name, d in distance.items() if low < d <= high}
        cells = [
            f"{len(p & inside)}/{len(inside)} ({100 * len(p & inside) / max(len(inside), 1):.0f} %)" for p in passes
        ]
        print(f"| {label} | {len(inside)} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
