"""The spaces of a model file against an environment's, by value: what the file keeps of its own
observation and action spaces (readable text beside the pickles) compared with the live spaces by
kind, shape, dtype and bounds, images as stable-baselines3 hands them to its policy."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from typing import Any, TypeGuard

import numpy as np

from aaai.scoring.model_archive import Archive, _refuse

# A file keeps its spaces as text: a Box's fields (shape, dtype, its bounds as numpy prints them) and
# a Dict's sub-spaces as their reprs. Gymnasium has changed what its spaces keep and print (1.4
# fills ``low_repr`` only when the space is printed), so spaces are compared by value: kind, shape,
# dtype and bounds, read from whichever form the file has.
_NUMBER = re.compile(r"[-+]?(?:inf|nan|\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)")
_BOX = re.compile(r"Box\((?P<low>[^,]+), (?P<high>[^,]+), \((?P<shape>[\d, ]*)\), (?P<dtype>\w+)\)", re.DOTALL)


def _bound(text: Any) -> np.ndarray | None:
    """A bound as numpy printed it (a scalar, or an array without commas); None when it was not
    kept or was shortened (numpy prints ``...`` for a large array)."""
    if not isinstance(text, str) or "..." in text:
        return None
    numbers = _NUMBER.findall(text)
    if not numbers or re.sub(r"[\[\]\s]", "", _NUMBER.sub("", text)):
        return None
    return np.array([float(n) for n in numbers], dtype=np.float64)


@dataclass(frozen=True)
class SpaceValue:
    """One space by value: its kind, shape, dtype and bounds (for a Box), and the text shown for it."""

    text: str
    kind: str
    shape: tuple | None = None
    dtype: str | None = None
    low: np.ndarray | None = dataclasses.field(default=None, compare=False)
    high: np.ndarray | None = dataclasses.field(default=None, compare=False)

    def agrees(self, other: "SpaceValue") -> bool:
        if self.kind != other.kind:
            return False
        if self.kind != "Box":
            return self.text == other.text
        if (self.shape, self.dtype) != (other.shape, other.dtype):
            return False
        size = int(np.prod(self.shape)) if self.shape is not None else 0
        for mine, theirs in ((self.low, other.low), (self.high, other.high)):
            if mine is None or theirs is None:
                continue  # a bound the file does not keep in full: shape and dtype decide
            if mine.size not in (1, size) or theirs.size not in (1, size):
                return False
            a, b = np.broadcast_to(mine, (size,)), np.broadcast_to(theirs, (size,))
            if not np.allclose(a, b, rtol=1e-6, atol=1e-7, equal_nan=True):
                return False
        return True


def _box_text(text: str) -> SpaceValue:
    """A Box's repr (``Box(low, high, (shape), dtype)``) as a value; another space's as its text."""
    match = _BOX.fullmatch(text.strip())
    if match is None:
        return SpaceValue(text, text.split("(", 1)[0].strip())
    shape = tuple(int(n) for n in re.findall(r"\d+", match.group("shape")))
    return SpaceValue(text, "Box", shape, match.group("dtype"), _bound(match.group("low")), _bound(match.group("high")))


def _space_parts(text: str) -> dict[str, SpaceValue]:
    """A Dict space's repr ``{'a': Box(...), 'b': Box(...)}`` as {key: value}."""
    found = list(re.finditer(r"'([^']+)': ", text))
    parts = {}
    for i, match in enumerate(found):
        end = found[i + 1].start() if i + 1 < len(found) else len(text)
        parts[match.group(1)] = _box_text(text[match.end() : end].rstrip(" ,}"))
    return parts


def stored_space(archive: Archive, field: str) -> dict[str, SpaceValue] | None:
    """The space a file keeps, by value: {key: value} for a Dict space, {"": value} for a Box, a
    Discrete or a MultiDiscrete; None when the file keeps no readable description of it."""
    entry = archive.data.get(field)
    if not isinstance(entry, dict):
        return None
    kind = str(entry.get(":type:", ""))
    if kind.endswith(".Dict'>") and isinstance(entry.get("spaces"), str):
        return _space_parts(entry["spaces"])
    if kind.endswith(".Box'>") and isinstance(entry.get("_shape"), list):
        shape = tuple(int(n) for n in entry["_shape"])
        low = entry.get("low_repr") if isinstance(entry.get("low_repr"), str) else entry.get("low")
        high = entry.get("high_repr") if isinstance(entry.get("high_repr"), str) else entry.get("high")
        text = f"Box({low}, {high}, {shape}, {entry.get('dtype')})"
        return {"": SpaceValue(text, "Box", shape, str(entry.get("dtype")), _bound(low), _bound(high))}
    if kind.endswith(".MultiDiscrete'>"):
        counts, starts = _bound(entry.get("nvec")), _bound(entry.get("start"))
        if counts is None:
            return None
        return {"": _multi_discrete(counts, starts, str(entry.get("dtype")))}
    if kind.endswith(".Discrete'>"):
        start = entry.get("start")
        shown = "" if start in (None, 0, "0") else f", start={start}"
        text = f"Discrete({entry.get('n')}{shown})"
        return {"": SpaceValue(text, "Discrete")}
    return None


def _multi_discrete(counts: np.ndarray, starts: np.ndarray | None, dtype: str) -> SpaceValue:
    """A MultiDiscrete space by value, shown as gymnasium shows it (``MultiDiscrete([3 3 2])``)."""
    shown = "[" + " ".join(f"{int(n)}" for n in counts) + "]"
    if starts is not None and starts.any():
        shown += ", start=[" + " ".join(f"{int(n)}" for n in starts) + "]"
    return SpaceValue(f"MultiDiscrete({shown})", "MultiDiscrete", (len(counts),), dtype)


def _live_value(space) -> SpaceValue:
    from gymnasium import spaces

    if isinstance(space, spaces.MultiDiscrete) and space.nvec.ndim == 1:
        starts = np.asarray(space.start, np.float64)
        return _multi_discrete(np.asarray(space.nvec, np.float64), starts, str(space.dtype))
    if isinstance(space, spaces.Box):
        low, high = np.asarray(space.low, np.float64).ravel(), np.asarray(space.high, np.float64).ravel()
        return SpaceValue(repr(space), "Box", tuple(space.shape), str(space.dtype), low, high)
    return SpaceValue(repr(space), type(space).__name__)


def describe_space(space) -> dict[str, SpaceValue]:
    """:func:`stored_space` for a live gymnasium space."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return {key: _live_value(sub) for key, sub in space.spaces.items()}
    return {"": _live_value(space)}


def compare_spaces(name: str, model: dict[str, SpaceValue], live: dict[str, SpaceValue]) -> list[str]:
    """How a model's space (``model``) differs from the environment's, by value, one line per key."""
    problems = []
    for key in sorted(set(model) | set(live)):
        label = f"{name} {key!r}" if key else f"{name} space"
        mine, theirs = model.get(key), live.get(key)
        if mine is None or theirs is None or not mine.agrees(theirs):
            shown = [v.text if v is not None else "absent" for v in (mine, theirs)]
            problems.append(f"{label}: model {shown[0]}, environment {shown[1]}")
    return problems


def as_model_sees(observation_space):
    """The observation space as stable-baselines3 hands it to its policy: images channel-first (its
    VecTransposeImage turns an H x W x C image of the environment into C x H x W; the policy
    transposes each observation likewise as it acts)."""
    from gymnasium import spaces
    from stable_baselines3.common.preprocessing import is_image_space, is_image_space_channels_first
    from stable_baselines3.common.vec_env import VecTransposeImage

    def needs(space) -> TypeGuard[spaces.Box]:
        return is_image_space(space) and not is_image_space_channels_first(space)

    if isinstance(observation_space, spaces.Dict):
        if not any(needs(sub) for sub in observation_space.spaces.values()):
            return observation_space
        return spaces.Dict(
            {
                key: VecTransposeImage.transpose_space(sub, key) if needs(sub) else sub
                for key, sub in observation_space.spaces.items()
            }
        )
    return VecTransposeImage.transpose_space(observation_space) if needs(observation_space) else observation_space


def space_problems(archive: Archive, observation_space, action_space) -> list[str]:
    """How the file's spaces differ from the environment's, by value, one line each (empty: they
    agree). ``observation_space`` is the environment's own (images as it renders them)."""
    problems = []
    for field_name, space, name in (
        ("observation_space", as_model_sees(observation_space), "observation"),
        ("action_space", action_space, "action"),
    ):
        stored = stored_space(archive, field_name)
        if stored is None:
            raise _refuse(archive.path, field_name, "keeps no readable description of the space")
        problems += compare_spaces(name, stored, describe_space(space))
    return problems
