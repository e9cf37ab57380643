"""Reading an arena file's values: where each key stands (file and line), random draws, types.

Every problem is recorded with the file, the line and the key, and reading goes on, so one pass
over a file reports all of them (aaai.task.arena puts the parts together into a spec).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NoReturn

import numpy as np
import yaml

from aaai.config import ConfigError
from aaai.spec import SHAPES, AgentPose, ObjectSpec
from aaai.spec.behaviours import REGISTRY
from aaai.spec.kinds import FOOD_KINDS, OBJECT_KINDS, kind_class

OBJECT_KEYS = ("kind", "shape", "position", "size", "yaw", "colour", "mass", "behaviour", "timing", "on_overlap")
ON_OVERLAP = ("refuse", "redraw")  # an object that overlaps one before it: the arena is refused, or it is drawn again
AGENT_KEYS = ("x", "y", "yaw")
RANDOM_FORMS = ("uniform", "integers", "choice")
MAX_DRAWN_INTEGER = 10**15  # {integers: [low, high]}: numpy draws within int64, and no count or seed is larger


class Source:
    """A parsed file: its name and the line of every key and list item, by path."""

    def __init__(self, path: Path, node: yaml.Node):
        self.name = path.name
        self.offset = 0  # spec objects before the file's own (the arena walls)
        self.lines: dict[tuple, int] = {(): node.start_mark.line + 1}
        self._walk(node, ())

    def _walk(self, node, where: tuple) -> None:
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                here = where + (key.value,)
                self.lines[here] = key.start_mark.line + 1
                self._walk(value, here)
        elif isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                self.lines[where + (index,)] = item.start_mark.line + 1
                self._walk(item, where + (index,))

    def line(self, where: tuple) -> int:
        while where not in self.lines:
            where = where[:-1]
        return self.lines[where]

    def error(self, where: tuple, message: str) -> ConfigError:
        return ConfigError(f"{self.name} line {self.line(where)}, {describe(where)}: {message}")


def describe(where: tuple) -> str:
    if not where:
        return "the file"
    text = str(where[0])
    for part in where[1:]:
        text += f"[{part}]" if isinstance(part, int) else f".{part}"
    return text


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class ArenaProblems(ConfigError):
    """Every problem found in an arena file, each naming the file, its line and the key (``problems``);
    as a message, one per line."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class Skip(Exception):
    """A part of the file that cannot be read; its problem is recorded and reading goes on."""


class Reader:
    """Turns the parsed YAML into spec fields, drawing the random numbers and checking types.
    Every problem is recorded (``problems``), and the parts that can still be read are read, so
    that one pass over a file reports all of them."""

    def __init__(self, source: Source, rng: np.random.Generator, data: dict):
        self.source, self.rng, self.data = source, rng, data
        self.problems: list[str] = []

    def fail(self, where: tuple, message: str) -> NoReturn:
        self.problems.append(str(self.source.error(where, message)))
        raise Skip

    def attempt(self, make, default=None):
        """``make()``, or ``default`` when the part it reads has a problem (recorded)."""
        try:
            return make()
        except Skip:
            return default

    def keys(self, mapping, allowed: tuple, where: tuple, required: tuple = (), strict: bool = True) -> None:
        """Records every unknown and missing key; with ``strict``, then skips the part."""
        if not isinstance(mapping, dict):
            self.fail(where, f"got {mapping!r}; allowed: a mapping with keys {', '.join(allowed)}")
        before = len(self.problems)
        for key in mapping:
            if key not in allowed:
                self.problems.append(
                    str(self.source.error(where + (key,), f"key {key!r} does not exist; allowed: {', '.join(allowed)}"))
                )
        for key in required:
            if key not in mapping:
                self.problems.append(str(self.source.error(where, f"key {key!r} is missing")))
        if strict and len(self.problems) > before:
            raise Skip

    def draw(self, value, where: tuple):
        """A value, with a randomisation form replaced by its draw."""
        if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in RANDOM_FORMS:
            form, args = next(iter(value.items()))
            here = where + (form,)
            if form == "choice":
                if not isinstance(args, list) or not args:
                    self.fail(here, f"got {args!r}; allowed: a list of one or more values to choose from")
                return args[int(self.rng.integers(len(args)))]
            if not (
                isinstance(args, list)
                and len(args) == 2
                and all(_number(a) for a in args)
                and all(math.isfinite(a) for a in args)
                and args[0] <= args[1]
                and math.isfinite(float(args[1]) - float(args[0]))  # numpy draws only over a finite span
            ):
                self.fail(here, f"got {args!r}; allowed: [low, high], two finite numbers, low <= high, a finite span")
            if form == "integers":
                if not all(float(a).is_integer() and abs(a) <= MAX_DRAWN_INTEGER for a in args):
                    self.fail(here, f"got {args!r}; allowed: [low, high], two integers within ±{MAX_DRAWN_INTEGER:.0e}")
                return int(self.rng.integers(int(args[0]), int(args[1]) + 1))
            return float(self.rng.uniform(args[0], args[1]))
        return value

    def number(self, value, where: tuple, integer: bool = False, positive: bool = False):
        value = self.draw(value, where)
        ok = _number(value) and math.isfinite(value)
        if integer:
            ok = ok and float(value).is_integer()
        if positive:
            ok = ok and value > 0
        if not ok:
            what = "an integer" if integer else "a finite number"
            extra = " (or {uniform: [low, high]}, {integers: [low, high]}, {choice: [...]})"
            self.fail(where, f"got {value!r}; allowed: {what}{' above 0' if positive else ''}{extra}")
        return int(value) if integer and not isinstance(value, int) else value

    def numbers(self, value, where: tuple, count: int | None, integer: bool = False, positive: bool = False) -> tuple:
        value = self.draw(value, where)
        if not isinstance(value, list) or (count is not None and len(value) != count):
            size = f"{count} numbers" if count is not None else "numbers"
            self.fail(where, f"got {value!r}; allowed: a list of {size}")
        return tuple(self.number(v, where + (i,), integer, positive) for i, v in enumerate(value))

    def text(self, value, where: tuple, choices: tuple | None = None) -> str:
        value = self.draw(value, where)
        if not isinstance(value, str) or (choices is not None and value not in choices):
            allowed = "one of " + ", ".join(choices) if choices else "a string"
            self.fail(where, f"got {value!r}; allowed: {allowed}")
        return value

    def plain(self, value, where: tuple):
        """Any plain data, with randomisation forms drawn anywhere inside it."""
        value = self.draw(value, where)
        if isinstance(value, dict):
            return {k: self.plain(v, where + (k,)) for k, v in value.items()}
        if isinstance(value, list):
            return [self.plain(v, where + (i,)) for i, v in enumerate(value)]
        return value

    # --- the parts ------------------------------------------------------------------
    def agent(self, value) -> AgentPose:
        where = ("agent",)
        self.keys(value, AGENT_KEYS, where, required=("x", "y"))
        return AgentPose(
            self.number(value["x"], where + ("x",)),
            self.number(value["y"], where + ("y",)),
            self.number(value.get("yaw", math.pi / 2), where + ("yaw",)),
        )

    def obj(self, value, index: int) -> ObjectSpec:
        where = ("objects", index)
        before = len(self.problems)
        self.keys(value, OBJECT_KEYS, where, required=("kind", "position", "size"), strict=False)
        kind = (
            self.attempt(lambda: self.text(value["kind"], where + ("kind",), OBJECT_KINDS)) if "kind" in value else None
        )
        shape = self.attempt(lambda: self.text(value.get("shape", default_shape(kind)), where + ("shape",), SHAPES))
        position = (
            self.attempt(lambda: self.numbers(value["position"], where + ("position",), 3))
            if "position" in value
            else None
        )
        size = (
            self.attempt(lambda: self.numbers(value["size"], where + ("size",), 3, positive=True))
            if "size" in value
            else None
        )
        yaw = self.attempt(lambda: self.number(value.get("yaw", 0.0), where + ("yaw",)), 0.0)
        colour = self.attempt(lambda: self._colour(value, where))
        mass = self.attempt(lambda: self.number(value.get("mass", 0.0), where + ("mass",)), 0.0)
        if mass < 0:
            self.attempt(lambda: self.fail(where + ("mass",), f"got {mass!r}; allowed: 0 (static) or more"))
        behaviour = self.attempt(lambda: self._behaviour(value, where))
        timing = self.attempt(lambda: self.plain(value.get("timing"), where + ("timing",)))
        self.attempt(lambda: self.text(value.get("on_overlap", "refuse"), where + ("on_overlap",), ON_OVERLAP))
        if len(self.problems) > before:
            raise Skip
        assert kind is not None and position is not None and size is not None  # else a problem was recorded
        try:
            return ObjectSpec(kind, shape, position, size, yaw, colour, mass, behaviour, timing)
        except ValueError as error:
            self.fail(where, str(error))

    def _colour(self, value: dict, where: tuple):
        colour = self.draw(value.get("colour"), where + ("colour",))
        return None if colour is None else self.numbers(colour, where + ("colour",), 4)

    def _behaviour(self, value: dict, where: tuple):
        behaviour = self.plain(value.get("behaviour"), where + ("behaviour",))
        if behaviour is not None:
            if not isinstance(behaviour, dict) or behaviour.get("type") not in REGISTRY:
                self.fail(
                    where + ("behaviour",),
                    f"got {behaviour!r}; allowed: null or a mapping with type one of "
                    f"{', '.join(REGISTRY)} and its fields",
                )
            fields = REGISTRY[behaviour["type"]].fields
            for key in behaviour:
                if key != "type" and key not in fields:
                    self.fail(
                        where + ("behaviour", key),
                        f"key {key!r} does not exist for {behaviour['type']}; allowed: type, {', '.join(fields)}",
                    )
            missing = [f for f in fields if f not in behaviour]
            if missing:
                self.fail(where + ("behaviour",), f"behaviour {behaviour['type']!r} lacks {', '.join(missing)}")
        return behaviour

    def optional(self, key: str, make):
        value = self.draw(self.data.get(key), (key,))
        return None if value is None else make(value)


def default_shape(kind: str | None) -> str:
    """The shape an object of this kind has when the file does not say: food a sphere, a newer
    kind its own (aaai.spec.kinds), anything else a box."""
    cls = kind_class(kind) if kind else None
    if cls is not None:
        return cls.shape
    return "sphere" if kind in FOOD_KINDS else "box"
