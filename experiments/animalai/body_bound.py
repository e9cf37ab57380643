"""How many of Animal-AI's 900 competition files can be valid for this body at most?
(experiments/animalai/body_bound.md)

Reads the import's coverage (``coverage.csv``: one row per file) and, of the files not valid on every
seed, puts each in the first of these groups it meets; the files in them cannot be made valid by any
change to the importer, the validator or the reference, only by another body or other tasks:

1. ``no body can pass``: every piece is in reach and all of them together give less than the pass mark
   (coverage.csv's cause; 07-13);
2. ``food high on static supports``: no ramp and no movable object in the arena, and every piece of
   positive value rests 3 Animal-AI units (15 here) or more above the floor on walls (as converted; a
   piece whose file fails because it cuts into the thin rails it lies on, which are not modelled,
   at the height Animal-AI gives it). The head reaches 3.8 above what the feet stand on, and nothing in
   such an arena lifts the body;
3. ``needs a step down of 5 or more``: the agent starts on a raised floor 5 or more high
   (``extras.animalai.start_height``) with the food below it (coverage.csv's cause), or on one the import
   keeps it on (a wall's top Animal-AI's agent walks on, with no floor beside a ledge: the ``unfair``
   column), and the food cannot be reached even with every ramp walkable (the first relaxed import
   below). The body lands on its back from 5, 10 and 15 whichever way it walks off (``step_down.py``,
   steps.md);
4. ``needs a ramp steeper than 21.8°``: valid when the validator takes every ramp as walkable (and
   steps up to 0.9), not valid when it takes ramps up to 21.8° as walkable (and steps up to 0.9). The
   gait does not get on to a ramp of 21.8° upright, crouched, or with 4 times the grip (``ramp_climb.py``,
   ramps.md), and climbs a step of 0.9 only after about 30 touches (``step_climb.py``, steps.md), so both
   imports are generous to the body.

Groups 1 and 2 fail for Animal-AI's own agent too; 3 and 4 for this body. Every other file not valid is
``other``: what it needs could still be built (pushing, tool use, scale, ...), so the bound counts it
as if it were. The two relaxed imports of the not-valid files (3 to 5 CPU-minutes each) are made under
WORK and kept there: a second call reuses them.

    python experiments/animalai/body_bound.py COMPETITION IMPORTED WORK [--coverage experiments/animalai/coverage.csv]

COMPETITION: Animal-AI's ``configs/competition``; IMPORTED: the import the coverage describes (its
``--out``); WORK: a folder of this script's own. Writes ``body_bound.csv`` beside the coverage and
prints the table of body_bound.md.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

from aaai.files import write_atomic
from aaai.safe_yaml import load_mapping
from aaai.task.arena import parse_arena
from aaai.tools.animalai import read_arena_config
from aaai.tools.animalai_fit import RAISED

HIGH = 3.0  # Animal-AI units: food resting this high or more is out of the head's reach (3.8 at scale 5)
DROP = 5.0  # units: a start this high or more above the food's floor (the body lands on its back)
RELAXED = {  # name: (RAMP_MAX_RISE, TERRAIN_STEP) of aaai.levels.validate in that import
    "every_ramp": (100.0, 0.9),
    "ramps_to_21.8": (math.tan(math.radians(21.8)), 0.9),
}
POSITIVE = ("GoodGoal", "GoodGoalMulti", "GoodGoalBounce", "GoodGoalMultiBounce")
MOVABLE = ("Cardbox1", "Cardbox2", "LightBlock", "HeavyBlock", "UObject", "LObject", "LObject2", "JObject")
IMPORT = """
import sys
import aaai.levels.validate as v
v.RAMP_MAX_RISE, v.TERRAIN_STEP = {rise!r}, {step!r}
from cli.main import cli
sys.argv = ["aaai", "import-animalai", {sources!r}, "--out", {out!r}, "--report", {report!r}]
cli()
"""


def relaxed_import(name: str, sources: Path, work: Path) -> set[str]:
    """The source files valid on every seed in an import with the validator relaxed as RELAXED[name]."""
    report = work / name
    table = report / "coverage.csv"
    if not table.exists():
        report.mkdir(parents=True, exist_ok=True)
        rise, step = RELAXED[name]
        code = IMPORT.format(rise=rise, step=step, sources=str(sources), out=str(report / "arenas"), report=str(report))
        root = Path(__file__).resolve().parents[2]
        subprocess.run([sys.executable, "-c", code], check=True, cwd=root, stdout=subprocess.DEVNULL)
    with table.open() as f:
        return {row["source"] for row in csv.DictReader(f) if row["valid_every_seed"] == "yes"}


def source_items(path: Path) -> list[dict]:
    """Animal-AI's items of the file's first arena, read as the importer reads them."""
    arena = next(iter(read_arena_config(path)["arenas"].values()))
    return arena.get("items") or []


def high_on_static(row: dict, source: Path, imported: Path) -> bool:
    items = source_items(source)
    names = {item["name"] for item in items}
    if "Ramp" in names or names & set(MOVABLE):
        return False
    if "cuts into" in (row["first_problem"] or ""):  # resting on rails that are not modelled: Animal-AI's height
        heights = [p["y"] for item in items if item["name"] in POSITIVE for p in item.get("positions") or []]
        return bool(heights) and min(heights) >= HIGH
    spec, _, _ = parse_arena(imported / row["file"])
    scale = spec.arena_size[0] / 40.0
    bottoms = [food.position[2] - food.size[2] / 2 for food in spec.foods if food.food_value > 0]
    return bool(bottoms) and min(bottoms) >= HIGH * scale


def group(row: dict, source: Path, imported: Path, every_ramp: set[str], gait_ramps: set[str]) -> str:
    if row["cause"] == "a pass mark above all the arena's food pays":
        return "no body can pass"
    if high_on_static(row, source, imported):
        return "food high on static supports"
    below = row["cause"] == "start on a raised floor, the food below it"
    if (below or row["unfair"] == RAISED) and row["source"] not in every_ramp:
        data = load_mapping(imported / row["file"], "arena file")
        if float(((data.get("extras") or {}).get("animalai") or {}).get("start_height") or 0) >= DROP:
            return "needs a step down of 5 or more"
    if row["source"] in every_ramp and row["source"] not in gait_ramps:
        return "needs a ramp steeper than 21.8°"
    return "other"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("competition", type=Path)
    parser.add_argument("imported", type=Path)
    parser.add_argument("work", type=Path)
    parser.add_argument("--coverage", type=Path, default=Path("experiments/animalai/coverage.csv"))
    args = parser.parse_args()
    with args.coverage.open() as f:
        rows = list(csv.DictReader(f))
    missing = [row for row in rows if row["valid_every_seed"] != "yes"]
    sources = args.work / "sources"
    sources.mkdir(parents=True, exist_ok=True)
    for row in missing:
        if not (sources / row["source"]).exists():
            shutil.copy(args.competition / row["source"], sources / row["source"])
    every_ramp = relaxed_import("every_ramp", sources, args.work)
    gait_ramps = relaxed_import("ramps_to_21.8", sources, args.work)
    found = []
    for row in missing:
        found.append((row, group(row, args.competition / row["source"], args.imported, every_ramp, gait_ramps)))
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["source", "category", "group", "cause"])
    for row, name in found:
        writer.writerow([row["source"], row["category"], name, row["cause"]])
    write_atomic(args.coverage.parent / "body_bound.csv", out.getvalue())
    counts = Counter(name for _, name in found)
    by_category: dict[str, Counter] = {}
    for row, name in found:
        by_category.setdefault(name, Counter())[row["category"]] += 1
    valid = len(rows) - len(missing)
    print(f"| | files | by category |\n|---|---:|---|\n| valid on every seed now | {valid} | |")
    print(f"| not valid | {len(missing)} | |")
    for name in (
        "no body can pass",
        "food high on static supports",
        "needs a step down of 5 or more",
        "needs a ramp steeper than 21.8°",
        "other",
    ):
        cats = ", ".join(f"{c} {n}" for c, n in sorted(by_category.get(name, Counter()).items()))
        print(f"| {name} | {counts[name]} | {cats} |")
    never = len(missing) - counts["other"]
    best = len(rows) - never
    print(f"| **at most valid for this body** | **{best}** ({100 * best / len(rows):.1f} %) | |")
    print(f"\nrelaxed imports: {len(every_ramp)} valid with every ramp walkable, {len(gait_ramps)} with ramps to 21.8°")


if __name__ == "__main__":
    main()
