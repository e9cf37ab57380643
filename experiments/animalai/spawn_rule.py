"""Which items of Animal-AI's competition files does its ArenaBuilder leave out?
(experiments/animalai/spawn_rule.md)

Animal-AI's ArenaBuilder (ArenaBuilders.cs, SamplePositionRotation) places an item whose place the file
gives only if ``Physics.OverlapBox`` finds no collider there that is not a trigger: the box is the
item's bounds, each side 0.999 of the size asked for (Prefab.sizeAdjustment), raised 0.01
(Prefab.AdjustY), turned by its rotation. Otherwise the item is not placed, with no second try.

This script applies that rule in Animal-AI's own units, straight from the files and independently of
``aaai import-animalai`` (it shares only the plain overlap test of two turned rectangles,
aaai.sim.geometry.footprints_overlap), to the items whose bounds and colliders are plain: walls, transparent walls and
the pushable boxes (Cardbox1/2, LightBlock, HeavyBlock), whose collider is their box, and goals, whose
collider is a sphere and whose bounds a cube. An earlier item of another kind (ramp, tunnel, U/L/J
block, hollow box, dispenser, button, sign) is not tested against, as its collider is not its box: a
query that meets one of their bounds is counted as ``not measured``. Zones are triggers and block
nothing. Items with a random place (-1) and the agent are left aside.

    python experiments/animalai/spawn_rule.py COMPETITION [--out experiments/animalai/spawn_rule.csv]

COMPETITION: Animal-AI's ``configs/competition``. Writes a row per item left out and prints the counts.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

from aaai.sim.geometry import footprints_overlap
from aaai.tools.animalai import read_arena_config
from aaai.tools.animalai_arena import EXACT, ITEMS, TIMED, is_number

SHRINK = 0.999
LIFT = 0.01
BOXES = ("Wall", "WallTransparent", "Cardbox1", "Cardbox2", "LightBlock", "HeavyBlock")
GOALS = tuple(name for name, (_, form, _) in ITEMS.items() if form == "goal")
TRIGGERS = ("DeathZone", "HotZone", "DataZone")


def vector(value: object) -> tuple[float, float, float] | None:
    """A !Vector3 of given numbers (none of them -1), else None."""
    if not isinstance(value, dict) or not all(is_number(value.get(axis)) for axis in "xyz"):
        return None
    x, y, z = (float(value[axis]) for axis in "xyz")
    return None if -1 in (x, z) else (x, y, z)


def query(name: str, position, size, rotation: float) -> dict:
    """The box OverlapBox tests for an item: centre, half sides (x, y, z) and turn (radians about y)."""
    low, high = ITEMS[name][2]
    side = [min(max(s, lo), hi) * SHRINK for s, lo, hi in zip(size, low, high)]
    if name in GOALS:
        side = [side[0]] * 3  # a goal's size is its diameter
    x, y, z = position
    return {"c": (x, y + side[1] / 2 + LIFT, z), "h": [s / 2 for s in side], "r": math.radians(rotation)}


def corners(box: dict) -> list[tuple[float, float]]:
    (x, _, z), (hx, _, hz), r = box["c"], box["h"], box["r"]
    c, s = math.cos(r), math.sin(r)
    return [(x + u * c + v * s, z - u * s + v * c) for u, v in ((hx, hz), (hx, -hz), (-hx, -hz), (-hx, hz))]


def boxes_cut(a: dict, b: dict) -> bool:
    """Do two boxes turned about y overlap (touching is not overlapping)?"""
    if a["c"][1] + a["h"][1] <= b["c"][1] - b["h"][1] or b["c"][1] + b["h"][1] <= a["c"][1] - a["h"][1]:
        return False
    return footprints_overlap(corners(a), corners(b), gap=EXACT)


def box_meets_sphere(box: dict, centre, radius: float) -> bool:
    """Does a turned box overlap a sphere (its nearest point closer than the radius)?"""
    (x, y, z), (hx, hy, hz), r = box["c"], box["h"], box["r"]
    dx, dy, dz = centre[0] - x, centre[1] - y, centre[2] - z
    c, s = math.cos(r), math.sin(r)
    u, v = dx * c - dz * s, dx * s + dz * c  # into the box's own axes
    near = (max(-hx, min(hx, u)) - u, max(-hy, min(hy, dy)) - dy, max(-hz, min(hz, v)) - v)
    return math.hypot(*near) < radius


def arena_left_out(items: list) -> tuple[list[tuple[int, int, str, list[str]]], int]:
    """The items an arena's ArenaBuilder leaves out, as (item, entry, name, what it cuts), and the
    number of queries that met the bounds of a collider this script does not model."""
    placed: list[tuple[str, dict]] = []  # (name, box): boxes and goals placed
    others: list[dict] = []  # bounds of the other solids placed
    left, unmeasured = [], 0
    for index, item in enumerate(items):
        if not isinstance(item, dict) or item.get("name") in (None, "Agent", *TRIGGERS):
            continue
        name = item["name"]
        positions, sizes, rotations = (item.get(key) or [] for key in ("positions", "sizes", "rotations"))
        for entry in range(max(len(positions), len(sizes), len(rotations), 1)):
            position = vector(positions[entry]) if entry < len(positions) else None
            size = vector(sizes[entry]) if entry < len(sizes) else None
            rotation = rotations[entry] if entry < len(rotations) else 0 if name in GOALS else -1
            if position is None or size is None or not is_number(rotation) or rotation == -1:
                continue  # a random place, size or turn: drawn by Animal-AI until it fits
            if name not in BOXES and name not in GOALS:
                if name in ITEMS or name in TIMED:  # its bounds still block what comes after
                    others.append(query(name if name in ITEMS else "GoodGoal", position, size, float(rotation)))
                continue
            box = query(name, position, size, float(rotation))
            cut = [
                other
                for other, placed_box in placed
                if (
                    box_meets_sphere(box, placed_box["c"], placed_box["h"][0])
                    if other in GOALS
                    else boxes_cut(box, placed_box)
                )
            ]
            if cut:
                left.append((index, entry, name, cut))
                continue
            unmeasured += any(boxes_cut(box, other) for other in others)
            placed.append((name, box))
    return left, unmeasured


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("competition", type=Path)
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("spawn_rule.csv"))
    args = parser.parse_args()
    rows, unmeasured, arenas = [], 0, 0
    for path in sorted(args.competition.glob("*.yaml")):
        for key, arena in read_arena_config(path)["arenas"].items():
            arenas += 1
            left, unknown = arena_left_out((arena or {}).get("items") or [])
            unmeasured += unknown
            rows += [(path.name, key, index, entry, name, " ".join(cut)) for index, entry, name, cut in left]
    with args.out.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["file", "arena", "item", "entry", "name", "cuts"])
        writer.writerows(rows)
    files = sorted({row[0] for row in rows})
    print(f"{arenas} arenas: {len(rows)} items left out, in {len(files)} files ({', '.join(files)})")
    print(f"queries that met the bounds of a collider not modelled (ramps, tunnels, U/L/J, ...): {unmeasured}")


if __name__ == "__main__":
    main()
