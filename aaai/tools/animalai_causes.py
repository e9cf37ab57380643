"""Why an imported Animal-AI arena is not valid for our body: the concrete cause of its first problem.

aaai.levels.validate names the problem (food out of reach, food cutting into a solid, solids
overlapping); this module names the cause behind it, for the import report
(aaai.tools.animalai_coverage, the ``cause`` column of coverage.csv). For food out of reach, the
first piece the body cannot reach is tried against the arena changed one way at a time, in this
order, and the first change that brings it within reach names the cause:

- ``food outside the arena``;
- ``food in a death zone``: the piece lies over a death zone (it must be brought out, or it moves);
- ``food on a platform up a ramp`` / ``food on top of a solid``: it rests on a solid's top (Animal-AI
  dropped it there), with or without a ramp whose high end meets that top;
- ``start on a raised floor, the food below it``: Animal-AI's agent starts on top of walls
  (``extras.animalai.start_height``) and walks on them, then steps down; here the body walks on a top wide enough for it
  (aaai.levels.validate.surface_heights) but does not step down from it, and a start on a narrower top
  was moved to the floor;
- ``behind a death zone``: reachable with the death zones taken away (Animal-AI's tasks that need a
  block pushed across one, or a ramp over it);
- ``behind a pushable block``: reachable with the movable blocks (planks, U, L, J blocks, hollow
  boxes) taken away;
- ``over a ramp the body does not climb``: reachable with the ramps taken away (a ramp steeper than
  aaai.levels.validate.RAMP_MAX_RISE is an obstacle, as is one whose foot is a step up);
- ``passage narrower than the body``: reachable by Animal-AI's agent (a sphere 1 across, ANIMALAI_RADIUS
  Animal-AI units in radius at the arena's scale), not by ours;
- ``walled off``: none of these.

From a start on a ledge (aaai.levels.validate.start_ledge) every piece may be reached and yet no one side
hold enough for the pass mark: ``one side's food below the pass mark`` (ONE_SIDE). With every piece in reach,
all of them together may give less than the pass mark: ``a pass mark above all the arena's food pays``
(ABOVE_ALL; no body can pass such a task).

A problem that is not food out of reach is named by the kinds it involves (``food cuts into a
ramp``, ``movable blocks overlap``, ...).
"""

from __future__ import annotations

import dataclasses
import math
import re

from aaai.spec import LevelSpec, ObjectSpec

ANIMALAI_RADIUS = 0.5  # Animal-AI's agent: a sphere 1 across, in Animal-AI units
RAMP_MEETS = 1.0  # units: a ramp's high end this close to a solid, and its top this close in height, leads up

# The causes, in the order they are tried (the report lists them in this order too).
OUT_OF_REACH = (
    "food outside the arena",
    "food in a death zone",
    "food on a platform up a ramp",
    "food on top of a solid",
    "start on a raised floor, the food below it",
    "behind a death zone",
    "behind a pushable block",
    "over a ramp the body does not climb",
    "passage narrower than the body",
    "walled off",
)


def _scale(spec: LevelSpec) -> float:
    return spec.arena_size[0] / 40.0


def _reachable(spec: LevelSpec, food: ObjectSpec, radius: float | None = None) -> bool:
    """Can a body of footprint ``radius`` (default: ours, validate's) reach the piece from the start?"""
    import cv2
    import numpy as np

    from aaai.levels import validate

    if radius is None:
        region, clear = validate.reachable_region(spec)
        return clear and validate.food_reachable(spec, region, food)
    clearance = validate.clearance_map(spec)  # Animal-AI's agent: validate's search with its footprint
    _, labels = cv2.connectedComponents((clearance > radius).astype(np.uint8), connectivity=8)
    start = labels[validate.cell(spec, spec.agent.x, spec.agent.y, clearance.shape)]
    return bool(start) and validate.food_reachable(spec, labels == start, food)


def _without(spec: LevelSpec, drop) -> LevelSpec:
    return dataclasses.replace(spec, objects=tuple(obj for obj in spec.objects if not drop(obj)))


def _over(obj: ObjectSpec, x: float, y: float) -> bool:
    """Is the point (x, y) over an object's footprint?"""
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    u, v = c * (x - obj.position[0]) + s * (y - obj.position[1]), -s * (x - obj.position[0]) + c * (y - obj.position[1])
    return abs(u) <= obj.size[0] / 2 and abs(v) <= obj.size[1] / 2


def support(spec: LevelSpec, food: ObjectSpec) -> ObjectSpec | None:
    """The solid a piece of food rests on (its top at the food's bottom, beneath its centre), if any."""
    from aaai.levels.validate import RAMP_REST, ramp_clearance
    from aaai.spec.kinds import SOLID_KINDS

    bottom = food.position[2] - food.size[2] / 2
    if bottom < 0.01:
        return None
    for obj in spec.objects:  # resting on a ramp's slope: what the ramp stands on, if anything
        if obj.kind == "ramp":
            clear = ramp_clearance(obj, food.position[0], food.position[1], food.position[2], food.size[0] / 2)
            if clear is not None and abs(clear) < RAMP_REST:
                under = obj.position[2] - obj.size[2] / 2
                lower = dataclasses.replace(
                    food, position=(food.position[0], food.position[1], under + food.size[2] / 2)
                )
                return support(spec, lower) if under > 0.01 else None
    for obj in spec.objects:
        top = obj.position[2] + obj.size[2] / 2
        if obj.kind in SOLID_KINDS and abs(top - bottom) < 0.01 and _over(obj, food.position[0], food.position[1]):
            return obj
    return None


def platform(spec: LevelSpec, solid: ObjectSpec) -> list[ObjectSpec]:
    """The static solids whose tops are as high as this one's (within RAMP_MEETS) and that touch it
    or each other (within RAMP_MEETS): one platform to walk on, made of several walls."""
    from aaai.sim.geometry import corners, footprints_overlap

    def top(obj: ObjectSpec) -> float:
        return obj.position[2] + obj.size[2] / 2

    level = [
        o for o in spec.objects if o.kind in ("wall", "transparent_wall") and abs(top(o) - top(solid)) <= RAMP_MEETS
    ]
    found, todo = [solid], [solid]
    while todo:
        here = corners(todo.pop())
        for other in level:
            if not any(other is f for f in found) and footprints_overlap(here, corners(other), gap=RAMP_MEETS):
                found.append(other)
                todo.append(other)
    return found


def ramp_leads_up(spec: LevelSpec, solid: ObjectSpec) -> bool:
    """Does a ramp's high end meet the top of this solid's platform (:func:`platform`): as high,
    within RAMP_MEETS, and beside it?"""
    from aaai.sim.geometry import corners, footprints_overlap

    top = solid.position[2] + solid.size[2] / 2
    tops = [corners(obj) for obj in platform(spec, solid)]
    for ramp in spec.objects:
        if ramp.kind != "ramp" or abs(ramp.position[2] + ramp.size[2] / 2 - top) > RAMP_MEETS:
            continue
        c, s = math.cos(ramp.yaw), math.sin(ramp.yaw)
        end = (ramp.position[0] + c * ramp.size[0] / 2, ramp.position[1] + s * ramp.size[0] / 2)
        half = ramp.size[1] / 2  # the high edge, a thin strip across the ramp
        edge = [
            (end[0] - s * half, end[1] + c * half),
            (end[0] + s * half, end[1] - c * half),
            (end[0] + s * half + c * 0.01, end[1] - c * half + s * 0.01),
            (end[0] - s * half + c * 0.01, end[1] + c * half + s * 0.01),
        ]
        if any(footprints_overlap(edge, quad, gap=RAMP_MEETS) for quad in tops):
            return True
    return False


def unreachable_cause(spec: LevelSpec, food: ObjectSpec) -> str:
    """Why the body cannot reach a piece of food (one of OUT_OF_REACH)."""
    from aaai.levels.validate import food_places
    from aaai.spec.kinds import kind_class

    x, y, _ = food_places(food)[-1]
    radius = food.size[0] / 2
    if abs(x) + radius > spec.arena_size[0] / 2 or abs(y) + radius > spec.arena_size[1] / 2:
        return "food outside the arena"

    def deadly(obj: ObjectSpec) -> bool:
        cls = kind_class(obj.kind)
        return cls is not None and cls.deadly

    if any(deadly(obj) and _over(obj, x, y) for obj in spec.objects):
        return "food in a death zone"
    below = support(spec, food)
    if below is not None:
        return "food on a platform up a ramp" if ramp_leads_up(spec, below) else "food on top of a solid"
    record = spec.extras.get("animalai") or {}
    if record.get("start_height") and not record.get("start_ledge"):  # (from a ledge, the floor is walked)
        return "start on a raised floor, the food below it"
    if _reachable(_without(spec, deadly), food):
        return "behind a death zone"
    if _reachable(_without(spec, lambda obj: obj.mass > 0), food):
        return "behind a pushable block"
    if _reachable(_without(spec, lambda obj: obj.kind == "ramp"), food):
        return "over a ramp the body does not climb"
    if _reachable(spec, food, ANIMALAI_RADIUS * _scale(spec)):
        return "passage narrower than the body"
    return "walled off"


_CUT = re.compile(r"\((\w+)\): .*cuts into objects\[\d+\] \((\w+)\)")
_OVERLAP = re.compile(r"\((\w+)\): at .* overlaps objects\[\d+\] \((\w+)\)")


def problem_cause(spec: LevelSpec | None, problem: str) -> str:
    """The concrete cause of one problem aaai.task.arena.check_arena found in ``spec`` (None: the file
    did not load): for food out of reach, the cause for its first piece out of reach (unreachable_cause)."""
    from aaai.tools.animalai_fit import cause

    found = cause(problem)
    divide = (spec.extras.get("animalai") or {}).get("start_on_divide") if spec is not None else None
    if found == "start not clear" and divide:
        from aaai.tools.animalai_fit import DIVIDE

        return divide if isinstance(divide, str) else DIVIDE
    if found == "food cuts into a solid":
        match = _CUT.search(problem)
        return f"food cuts into a {match.group(2)}" if match else found
    if found == "solids overlap":
        match = _OVERLAP.search(problem)
        if match:
            a, b = sorted((match.group(1), match.group(2)))
            movable = {"plank", "u_block", "l_block", "j_block", "hollow_box"}
            if a in movable and b in movable:
                return "movable blocks overlap"
            return f"{a} and {b} overlap"
        return "food on food" if "exactly where" in problem else found
    if found in ("reachable food below the pass mark", "food out of reach") and spec is not None:
        from aaai.levels import validate

        region, clear = validate.reachable_region(spec)
        for food in spec.foods:
            if not (clear and validate.food_reachable(spec, region, food)):
                return unreachable_cause(spec, food)
        if found == "reachable food below the pass mark" and validate.start_ledge(spec) is not None:
            return ONE_SIDE
        if found == "reachable food below the pass mark":
            from aaai.task.arena import ENDING_IN_THE_WAY, LAST_ENDS

            return (
                ENDING_IN_WAY
                if ENDING_IN_THE_WAY in problem
                else LAST_ENDS_CAUSE
                if LAST_ENDS in problem
                else ABOVE_ALL
            )
    return found


# every piece is reached, and all of them together give less than the pass mark (Animal-AI's 07-13)
ABOVE_ALL = "a pass mark above all the arena's food pays"
# every piece is reached, but the pass mark's pieces only past a green or a red, which ends the episode
ENDING_IN_WAY = "food that ends the episode in the way"
# the pass mark needs a green and every multi_food piece, and the last multi_food piece eaten ends the episode
LAST_ENDS_CAUSE = "the last multi_food ends the episode before the green"
# every piece is reached from a start on a ledge, but on no one side enough for the pass mark
ONE_SIDE = "one side's food below the pass mark (from a ledge the body steps down to one side)"
