"""Fitting an imported Animal-AI arena to our body (used by aaai.tools.animalai).

Animal-AI's agent is a sphere 1 across; our body's walking footprint is 10 across
(aaai.levels.validate.FOOTPRINT_RADIUS), so at the default scale some starts and passages that fit
Animal-AI's agent do not fit ours. An arena is converted at the asked scale and checked
(aaai.levels.validate) on seeds 0 to FIT_SEEDS - 1; when it fails:

- a fixed agent start that is not clear moves to the nearest clear place (the centre of a grid
  cell with room for the body), facing the same way; of the clear regions, the nearest one from
  which the food can be reached, else the nearest; but a start on top of a wall with a side of it
  about as near as the other (SIDE_MARGIN) is not moved: which side to take is the task. It is put on a
  ledge cut into the wall (place_ledge: LEDGE), from which the body steps down to either side and which
  it cannot climb back; where the ledge has no floor beside it (a wide wall's top, walked on by
  Animal-AI's agent) or cannot be cut, the arena is marked unfair (RAISED, DIVIDE);
- when food still cannot be reached (a passage narrower than the body) or the start has no clear
  place near, the arena is converted again at the next of SCALE_STEPS times the asked scale, and the
  smallest scale at which it is valid on every seed is kept;
- an arena valid at none of them is kept at the asked scale and marked unfair, with the problems
  found at the largest scale (``unfair``): a task that cannot be made fair for this body is named,
  never dropped.

Every change is recorded in the arena file (``extras: {animalai: {...}}``) and returned, for the
import report (aaai.tools.animalai_report).
"""

from __future__ import annotations

import copy
import math
import re
import tempfile
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from aaai.config import ConfigError

FIT_SEEDS = 10  # the seeds an arena must be valid on (those `aaai validate --arena` checks)
SCALE_STEPS = (1.0, 1.2, 1.4, 1.6)  # times the asked scale, tried in order
# the causes a start in another region may cure
REGION_CAUSES = {"start not clear", "food out of reach", "reachable food below the pass mark"}
START_MARGIN = 0.5  # units of room beyond the body's footprint radius a moved start keeps
# A start on top of a static box (Animal-AI's agent stands on it) whose two nearest clear regions lie
# within this many units of the same distance is on a divide (a wall between two sides, 02-03 and
# 09-01 alike): moving it to either side would make the choice the task asks of the agent, so it is
# not moved, and the arena is marked unfair.
SIDE_MARGIN = 5.0
DIVIDE = "start on a dividing wall (moved off it, the start would choose the side)"
# Such a start is put on a ledge instead (place_ledge): the body steps down from it to either side, as
# Animal-AI's agent does from the wall, and cannot climb back; the side is still the agent's choice.
LEDGE = "start on a ledge"
# A start on a wall's top so wide that a ledge cut into it has no floor beside it where the body fits
# (Animal-AI's agent walks along the top, a raised floor, before it steps down): marked unfair.
RAISED = "start on a raised floor (a wall's top Animal-AI's agent walks on, with no floor beside a ledge)"
LEDGE_HALF = 6.0  # units each way from the start: the body's footprint (5) and a margin
LEDGE_HEIGHT = 1.5  # under aaai.levels.validate.LEDGE_DROP (1.6), above its LEDGE_CLIMB (1.3)
LEDGE_CUTS = ("wall", "transparent_wall")  # the static kinds a dividing wall is made of, cut round a ledge


def _problems(text: str, name: str, seeds: int) -> list[list[str]]:
    """Each seed's validate problems of an arena file's text, up to the first seed with any."""
    from aaai.task.arena import check_arena, parse_arena

    found = []
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_text(text)
        for seed in range(seeds):
            try:
                spec, _, source = parse_arena(path, seed)
                found.append(check_arena(spec, source))
            except ConfigError as error:
                found.append(list(getattr(error, "problems", None) or [str(error)]))
            if found[-1]:  # one failing seed is enough to try the next change
                break
    return found


def _spec(text: str, name: str, seed: int = 0):
    from aaai.task.arena import parse_arena

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_text(text)
        return parse_arena(path, seed)[0]


def clear_places(spec) -> list[tuple[float, float]]:
    """One clear place per region the body can stand in, nearest first: the clear cell nearest the
    agent's start in each connected region of cells with room for the body."""
    from aaai.levels.validate import FOOTPRINT_RADIUS, GRID, TERRAIN_STEP, clearance_map, surface_heights

    clearance = clearance_map(spec)
    floor = surface_heights(spec)[0] <= TERRAIN_STEP  # a start is moved down to the floor, never on to a top
    free = ((clearance > FOOTPRINT_RADIUS + START_MARGIN) & floor).astype(np.uint8)
    count, labels = cv2.connectedComponents(free, connectivity=8)
    rows, cols = np.indices(labels.shape)
    xs = (cols + 0.5) * GRID - spec.arena_size[0] / 2
    ys = (rows + 0.5) * GRID - spec.arena_size[1] / 2
    distance = np.hypot(xs - spec.agent.x, ys - spec.agent.y)
    places = []
    for label in range(1, count):
        inside = labels == label
        best = np.argmin(np.where(inside, distance, np.inf))
        places.append((float(distance.flat[best]), float(xs.flat[best]), float(ys.flat[best])))
    return [(x, y) for _, x, y in sorted(places)]


def _box(obj: dict) -> tuple[tuple[float, float, float, float], bool] | None:
    """A static box's bounding footprint (x0, y0, x1, y1), and whether it is that footprint (turned by a
    multiple of a right angle); None when a number is not given."""
    numbers = (*obj.get("position", ()), *obj.get("size", ()), obj.get("yaw", 0.0))
    if len(numbers) != 7 or not all(isinstance(v, (int, float)) for v in numbers):
        return None
    yaw = obj.get("yaw", 0.0)
    quarter = yaw / (math.pi / 2)
    (x, y, _), (length, width, _) = obj["position"], obj["size"]
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    half_x, half_y = (c * length + s * width) / 2, (s * length + c * width) / 2
    return (x - half_x, y - half_y, x + half_x, y + half_y), abs(quarter - round(quarter)) < 1e-6


def _meets(box, x0: float, y0: float, x1: float, y1: float) -> bool:
    return not (box[2] <= x0 or box[0] >= x1 or box[3] <= y0 or box[1] >= y1)


def place_ledge(data: dict, top: float) -> str | None:
    """Puts the agent's start on a dividing wall (``top`` high) on a ledge: a static box (a pillar)
    LEDGE_HALF each way from the start (within the arena), widened to a wall's side where less than the
    body's width (2 x FOOTPRINT_RADIUS) of the wall would be left beside it (a strip the feet would catch
    on), as high as the wall or the highest step the body walks down upright
    (aaai.levels.validate.LEDGE_DROP), whichever is lower; the walls under it are cut round it (their
    pieces either side kept). The start stays where it is, facing the same way, and the ledge is recorded
    (``extras.animalai.start_ledge``); walls stacked on the wall are cut too, a bar above its top is left.
    Returns the change in words, or None when it cannot be placed (a wall under it turned other than by
    right angles; a wall too low)."""
    from aaai.levels.validate import FOOTPRINT_RADIUS, LEDGE_CLIMB, LEDGE_DROP

    assert LEDGE_CLIMB < LEDGE_HEIGHT <= LEDGE_DROP

    agent, (width, depth) = data["agent"], data["arena_size"]
    height = round(min(top, LEDGE_HEIGHT), 4)
    if height <= LEDGE_CLIMB:
        return None
    x0, x1 = max(agent["x"] - LEDGE_HALF, -width / 2), min(agent["x"] + LEDGE_HALF, width / 2)
    y0, y1 = max(agent["y"] - LEDGE_HALF, -depth / 2), min(agent["y"] + LEDGE_HALF, depth / 2)
    cut: list[int] = []  # the walls under the ledge
    for _ in range(3):  # widened, the ledge may meet another wall: looked at again
        before, cut = (x0, y0, x1, y1), []
        for index, obj in enumerate(data["objects"]):
            if obj.get("kind") not in LEDGE_CUTS or obj.get("mass") or obj.get("behaviour"):
                continue
            found = _box(obj)
            if found is None or not _meets(found[0], x0, y0, x1, y1):
                continue
            (a0, b0, a1, b1), square = found
            if obj["position"][2] - obj["size"][2] / 2 > top + 1e-6:  # above the wall's top: a bar overhead
                continue
            if not square:
                return None  # nothing is changed until every wall under the ledge can be cut
            cut.append(index)
            strip = 2 * FOOTPRINT_RADIUS
            x0, x1 = (a0 if 0 < x0 - a0 < strip else x0), (a1 if 0 < a1 - x1 < strip else x1)
            y0, y1 = (b0 if 0 < y0 - b0 < strip else y0), (b1 if 0 < b1 - y1 < strip else y1)
        if (x0, y0, x1, y1) == before:
            break
    kept, colour = [], None
    for index, obj in enumerate(data["objects"]):
        found = _box(obj) if index in cut else None
        if found is None:
            kept.append(obj)
            continue
        (a0, b0, a1, b1), _ = found
        z, tall = obj["position"][2], obj["size"][2]
        colour = colour or obj.get("colour")
        pieces = [
            (a0, b0, a1, y0),  # below the ledge, the wall's whole width
            (a0, y1, a1, b1),  # above it
            (a0, max(b0, y0), x0, min(b1, y1)),  # beside it, left and right
            (x1, max(b0, y0), a1, min(b1, y1)),
        ]
        for p0, q0, p1, q1 in pieces:
            if p1 - p0 > 1e-3 and q1 - q0 > 1e-3:
                piece = {**obj, "position": [round((p0 + p1) / 2, 4), round((q0 + q1) / 2, 4), z]}
                piece.update(size=[round(p1 - p0, 4), round(q1 - q0, 4), tall], yaw=0.0)
                kept.append(piece)
    ledge = {  # a static pillar: a solid box whose touch, unlike a wall's, costs nothing (stood on all the time)
        "kind": "pillar",
        "position": [round((x0 + x1) / 2, 4), round((y0 + y1) / 2, 4), round(height / 2, 4)],
        "size": [round(x1 - x0, 4), round(y1 - y0, 4), height],
        "yaw": 0.0,
    }
    if colour is not None:
        ledge["colour"] = colour
    data["objects"] = [*kept, ledge]
    record = {"at": [agent["x"], agent["y"]], "height": height, "wall_top": round(top, 4)}
    data.setdefault("extras", {}).setdefault("animalai", {})["start_ledge"] = record
    return LEDGE


def move_start(data: dict, dump: Callable[[dict], str], name: str) -> str | None:
    """Moves a fixed agent start that is not clear (seed 0) to the nearest clear place, facing the
    same way, recording the move in ``data["extras"]``; returns the change in words, or None."""
    agent = data["agent"]
    if not all(isinstance(agent.get(k), (int, float)) for k in ("x", "y")):
        return None  # drawn per seed: left as it is
    spec = _spec(dump(dict(data)), name)
    from aaai.levels.validate import reachable_region

    raised = (data.get("extras") or {}).get("animalai", {}).get("start_height")
    if reachable_region(spec)[1]:
        # clear; on a raised floor (a top wide enough for the body), kept there while the food it needs
        # can be reached from it, as Animal-AI's agent starts there
        if not raised or not {cause(p) for p in _problems(dump(dict(data)), name, 1)[0]} & REGION_CAUSES:
            return None
    places = clear_places(spec)
    if not places:
        return None
    if raised and len(places) > 1:
        near = [math.hypot(x - agent["x"], y - agent["y"]) for x, y in places[:2]]
        if near[1] - near[0] < SIDE_MARGIN:  # off a dividing wall: either side, and the move would choose
            trial = copy.deepcopy(data)
            ledge = place_ledge(trial, float(raised))
            if ledge and reachable_region(_spec(dump(dict(trial)), name))[1]:
                data.clear()
                data.update(trial)
                return ledge
            # no ledge, or none with floor beside it where the body fits: Animal-AI's agent walks on the top
            data.setdefault("extras", {}).setdefault("animalai", {})["start_on_divide"] = RAISED if ledge else DIVIDE
            return None
    chosen = places[0]
    for x, y in places[:8]:  # the nearest region from which the food can be reached, if one is near
        trial = {**data, "agent": {**agent, "x": round(x, 2), "y": round(y, 2)}}
        problems = _problems(dump(dict(trial)), name, 1)[0]
        if not {cause(p) for p in problems} & REGION_CAUSES:
            chosen = (x, y)
            break
    x, y = round(chosen[0], 2), round(chosen[1], 2)
    moved = math.hypot(x - agent["x"], y - agent["y"])
    record = {"from": [agent["x"], agent["y"]], "to": [x, y]}
    data["agent"] = {**agent, "x": x, "y": y}
    data.setdefault("extras", {}).setdefault("animalai", {})["start_moved"] = record
    return f"start moved ({moved:.1f} units, to clear the body)"


def fit(
    convert: Callable[[float], tuple[dict, list[str]]],
    dump: Callable[[dict], str],
    name: str,
    scale: float,
    seeds: int = FIT_SEEDS,
) -> tuple[dict, list[str], list[str], list[str]]:
    """The arena converted (``convert(scale)``) and fitted: its data, item names, the changes made
    and, if it is valid at no scale tried, the causes found at the largest (why it cannot be made
    fair for this body; else [])."""
    last: list[str] = []
    first = None
    for step in SCALE_STEPS:
        data, names = convert(scale * step)
        changes = []
        moved = move_start(data, dump, name)
        if moved:
            changes.append(moved)
        divide = (data.get("extras") or {}).get("animalai", {}).get("start_on_divide")
        if divide:
            reason = divide if isinstance(divide, str) else DIVIDE
            data["extras"]["animalai"]["unfair"] = reason
            return data, names, changes, [reason]
        problems = _problems(dump(dict(data)), name, seeds)
        if first is None:
            first = (data, names, changes)
        if not any(problems):
            if step != 1.0:
                data.setdefault("extras", {}).setdefault("animalai", {})["scale"] = round(scale * step, 4)
                changes.append(f"scale {scale * step:g} (passages narrower than the body at {scale:g})")
            return data, names, changes, []
        last = sorted({cause(p) for seed in problems for p in seed})
    assert first is not None
    data, names, changes = first
    reason = f"valid at no scale from {scale:g} to {scale * SCALE_STEPS[-1]:g}: " + ", ".join(last)
    data.setdefault("extras", {}).setdefault("animalai", {})["unfair"] = reason
    return data, names, changes, last


# A validate problem's cause, by the words of its message (aaai.levels.validate.check).
CAUSES = (
    ("start not clear", re.compile(r"agent's start .* is not clear")),
    ("solids overlap", re.compile(r"overlaps|is exactly where")),
    ("reachable food below the pass mark", re.compile(r"below the pass mark")),
    ("food out of reach", re.compile(r"cannot be reached")),
    ("food cuts into a solid", re.compile(r"cuts into")),
    ("food not on solid ground", re.compile(r"not on solid ground")),
    ("outside the arena", re.compile(r"outside the arena")),
    ("no food", re.compile(r"has no food")),
)


def cause(problem: str) -> str:
    """The cause a validate or import problem stands for (one of CAUSES, or its own words)."""
    for name, pattern in CAUSES:
        if pattern.search(problem):
            return name
    if "blackouts" in problem:
        return "blackouts at listed frames"
    found = re.search(r"cannot be mapped \(([^);]*)", problem)
    if found:
        return found.group(1)
    return problem.split(": ", 1)[-1][:80]
