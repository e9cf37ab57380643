"""``aaai import-animalai``: Animal-AI arena files (``!ArenaConfig``) read as plain data within
limits and written as aaai arena files, one per arena (each converted by aaai.tools.animalai_arena).

Several arenas in one file become several files (``NAME_aK.yaml``; one arena: ``NAME.yaml``). An
arena that cannot be mapped is skipped with its reason; a file that cannot be read is refused with
its reason, and the others are still converted. Every file is written atomically inside the output
folder. How the reference controller fares on the result: aaai.tools.animalai_coverage
(``python -m aaai.tools.animalai FOLDER [SAMPLE]``).
"""

from __future__ import annotations

import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from aaai import safe_yaml
from aaai.config import ConfigError
from aaai.files import write_atomic
from aaai.tools.animalai_arena import DEFAULT_SCALE, Unmappable, convert_arena, is_number, shown
from aaai.tools.animalai_fit import fit

IMPORT_SEED = 20260
UNFAIR = "unfair"  # the subfolder of --out for arenas that cannot be made fair for our body (aaai.tools.animalai_fit)
MAX_FILE_BYTES = 1_000_000


# --- reading ------------------------------------------------------------------------------
ANIMALAI_TAGS = ("!ArenaConfig", "!Arena", "!Item", "!Vector3", "!RGB")  # read as the plain mappings they tag
MAX_ALIASES = 100  # an Animal-AI file may reuse a value (*name) this often
MAX_VALUES = 100_000  # values once aliases are expanded: a file of 40 arenas of 100 items each needs about 30,000
MAX_ARENAS = 1000  # arenas in one file
LIMITS = safe_yaml.Limits(max_bytes=MAX_FILE_BYTES, aliases=MAX_ALIASES, max_values=MAX_VALUES, tags=ANIMALAI_TAGS)
_PLAIN_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")  # an arena's key, as it goes into a file name


def read_arena_config(path: Path) -> dict:
    """The parsed ``!ArenaConfig`` of a file, read as plain data within LIMITS (aaai.safe_yaml: no
    code, a few aliases, no deep nesting, no NUL, no huge numbers) and checked for its outline: a
    mapping of at most MAX_ARENAS arenas, each under a plain name (it goes into a file name)."""
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ConfigError(f"{path.name}: larger than {MAX_FILE_BYTES:,} bytes; allowed: an Animal-AI arena file")
    try:
        data = safe_yaml.load(path, "Animal-AI arena file", LIMITS)
    except safe_yaml.YAMLRefused as error:
        raise ConfigError(f"{path.name}: not Animal-AI arena YAML: {error.detail}") from None
    if not isinstance(data, dict) or not isinstance(data.get("arenas"), dict) or not data["arenas"]:
        raise ConfigError(
            f"{path.name}: got no 'arenas' mapping; allowed: an Animal-AI !ArenaConfig with arenas: "
            "{0: !Arena {...}}"
        )
    if len(data["arenas"]) > MAX_ARENAS:
        raise ConfigError(f"{path.name}: {len(data['arenas'])} arenas; allowed: at most {MAX_ARENAS} in one file")
    for key in data["arenas"]:
        if isinstance(key, bool) or not _PLAIN_NAME.fullmatch(str(key)):
            raise ConfigError(
                f"{path.name}: arena key {shown(key)} is not a plain name; allowed: 1 to 64 letters, digits, _ "
                "or - (e.g. 0, 1, 2), as it becomes part of a file name"
            )
    return data


# --- converting -------------------------------------------------------------------------------
@dataclass
class Converted:
    """One arena of a file: its output file and text, or why it was skipped."""

    source: str
    arena: str
    name: str
    text: str = ""
    problem: str = ""
    items: list[str] = field(default_factory=list)
    refused: bool = False  # the whole file was refused (unreadable, unsafe): ``arena`` and ``name`` are empty
    changes: list[str] = field(default_factory=list)  # what was changed to fit our body (a start moved, the scale)
    unfair: list[str] = field(default_factory=list)  # why the task cannot be made fair for our body


_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml's emitter when present: the same text, faster


def _dump(data: dict) -> str:
    """An arena file: the keys in order, one flow mapping per object."""
    objects = data.pop("objects")
    lines = ["# Imported from an Animal-AI arena file by `aaai import-animalai` (aaai/tools/animalai.py)."]
    for key, value in data.items():
        if isinstance(value, (list, dict)):
            lines.append(
                f"{key}: " + yaml.safe_dump(value, sort_keys=False, default_flow_style=True, width=10**6).strip()
            )
        else:
            lines.append(
                yaml.safe_dump({key: value}, sort_keys=False, default_flow_style=False, width=10**6).rstrip("\n")
            )
    lines.append("objects:" if objects else "objects: []")
    for obj in objects:
        lines.append(
            "  - " + yaml.dump(obj, Dumper=_DUMPER, sort_keys=False, default_flow_style=True, width=10**6).strip()
        )
    return "\n".join(lines) + "\n"


def convert_file(path: Path, scale: float = DEFAULT_SCALE, fitted: bool = True) -> list[Converted]:
    """Every arena of an Animal-AI file, converted or with the reason it was skipped; ``fitted``:
    fitted to our body (aaai.tools.animalai_fit: a start moved, a larger scale, or marked unfair)."""
    data = read_arena_config(path)
    arenas = data["arenas"]
    results = []
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", path.stem)[:100]  # a file name, whatever the source file's
    for number, (key, arena) in enumerate(arenas.items()):
        name = f"{stem}.yaml" if len(arenas) == 1 else f"{stem}_a{key}.yaml"  # the keys: plain names

        def convert(at: float, key=key, arena=arena, number=number) -> tuple[dict, list[str]]:
            rng = np.random.default_rng([IMPORT_SEED, zlib.crc32(path.name.encode()), number])
            return convert_arena(path.name, key, arena, at, rng)

        try:
            if fitted:
                out, names, changes, unfair = fit(convert, _dump, name, scale)
            else:
                (out, names), changes, unfair = convert(scale), [], []
        except Unmappable as error:
            results.append(Converted(path.name, str(key), name, problem=str(error)))
            continue
        record = (out.get("extras") or {}).get("animalai", {})
        rolled = record.get("rolled") or []
        if rolled:  # not a fit to our body: where Animal-AI's physics takes the goal (animalai_arena._rolled)
            pieces = f"{len(rolled)} piece{'s' if len(rolled) > 1 else ''}"
            changes = [f"goal rolled down a ramp, as in Animal-AI ({pieces})", *changes]
        crossing = record.get("walls_left_out") or []
        if crossing:  # nor this: Animal-AI's ArenaBuilder does not place them (animalai_arena._Arena._cuts_a_wall)
            walls = f"{len(crossing)} wall{'s' if len(crossing) > 1 else ''}"
            changes = [f"wall crossing an earlier wall left out, as in Animal-AI ({walls})", *changes]
        results.append(Converted(path.name, str(key), name, _dump(out), items=names, changes=changes, unfair=unfair))
    return results


def animalai_files(path: Path) -> list[Path]:
    path = Path(path)
    if path.is_dir():
        files = sorted(list(path.rglob("*.yaml")) + list(path.rglob("*.yml")))
        if not files:
            raise ConfigError(
                f"{str(path)!r} holds no .yaml files; allowed: an Animal-AI arena file or a folder of them"
            )
        return files
    if not path.is_file():
        raise ConfigError(f"{str(path)!r} is neither a file nor a folder; allowed: an Animal-AI arena file or a folder")
    return [path]


def import_animalai(
    source: Path, out: Path, scale: float = DEFAULT_SCALE, echo: Callable[[str], object] = print, fitted: bool = True
) -> list[Converted]:
    """Converts a file or a folder of them into ``out`` (one aaai arena file per arena), printing
    each skipped arena's reason and a summary; returns every arena's result, and one (``refused``)
    for each file that could not be read. Every file is written inside ``out``: a name leading
    elsewhere is refused (``refused``), as is a second arena of the same name (skipped)."""
    if not (is_number(scale) and 0.1 <= scale <= 20):
        raise ConfigError(f"--scale: got {scale!r}; allowed: a number from 0.1 to 20")
    files = animalai_files(source)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    folder = out.resolve()
    results: list[Converted] = []
    written: dict[str, str] = {}  # output name -> the file and arena it came from
    unreadable = 0
    for path in files:
        try:
            converted = convert_file(path, scale, fitted)
        except ConfigError as error:
            echo(f"SKIPPED {error}")
            unreadable += 1
            results.append(Converted(path.name, "", "", problem=str(error), refused=True))
            continue
        for result in converted:
            if not result.problem:
                target = (out / result.name).resolve()
                if target.parent != folder:  # a name that leads elsewhere (a link in --out) is refused
                    result.problem = f"{result.source}, arena {result.arena}: {result.name} lies outside {out}"
                    result.refused = True
                elif result.name in written:
                    result.problem = (
                        f"{result.source}, arena {result.arena}: {result.name} was already written from "
                        f"{written[result.name]}; arena skipped"
                    )
            if result.problem:
                echo(f"SKIPPED {result.problem}")
            else:
                if result.unfair:  # kept, apart: `aaai eval --arenas OUT` runs the fair ones
                    (out / UNFAIR).mkdir(exist_ok=True)
                    write_atomic(out / UNFAIR / result.name, result.text)
                    echo(f"UNFAIR {result.source}, arena {result.arena}: {', '.join(result.unfair)}; in {UNFAIR}/")
                else:
                    write_atomic(out / result.name, result.text)
                written[result.name] = f"{result.source}, arena {result.arena}"
        results += converted
    arenas = [r for r in results if r.arena or not r.refused]  # a refused file's entry is no arena
    done = [r for r in arenas if not r.problem]
    kinds: dict[str, int] = {}
    for result in done:
        for name in result.items:
            kinds[name] = kinds.get(name, 0) + 1
    echo(
        f"{len(files)} files, {len(arenas)} arenas: {len(done)} converted into {out}, "
        f"{len(arenas) - len(done)} skipped" + (f", {unreadable} files unreadable" if unreadable else "")
    )
    unfair = [r for r in done if r.unfair]
    if unfair:
        echo(f"{len(unfair)} of them cannot be made fair for this body: kept in {out / UNFAIR}, each named above")
    if kinds:
        echo("items converted: " + ", ".join(f"{name} {count}" for name, count in sorted(kinds.items())))
    reasons: dict[str, int] = {}
    for result in arenas:
        if result.problem:
            reason = result.problem.split(": ", 1)[-1]
            reasons[reason] = reasons.get(reason, 0) + 1
    for reason, count in sorted(reasons.items(), key=lambda kv: -kv[1]):
        echo(f"  skipped {count}: {reason}")
    return results


if __name__ == "__main__":
    import sys

    from aaai.tools.animalai_coverage import coverage

    coverage(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 0)
