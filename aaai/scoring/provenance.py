"""What a scoreboard was scored with (its provenance): the policy's record, the seeds, the
environment's config and digest, the action mode, the package version and the numerics, kept as
``*_scored_with.json`` beside the CSV; an eval that resumes a scoreboard scored otherwise is refused,
naming each key that differs. A scoreboard of arena files also records each file's SHA-256
(``arena_sha256``, :func:`arena_hashes`): a file changed since is refused by name
(:func:`check_arena_hashes`)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Iterable

from aaai.config import Config, ConfigError, env_part, load_config
from aaai.files import file_sha256
from aaai.levels.seeds import key_record
from aaai.scoring.policies import Policy, as_policy


def policy_record(policy: Policy | str, seeds: str, key: str | None = None) -> dict:
    """What a scoreboard was scored with: the policy's record (its model file and hash, or its
    source's hash), the seeds and the seed key's record. An eval that resumes a scoreboard must match it."""
    return {**as_policy(policy).record, "seeds": seeds, "seed_key": key_record(key)}


def record_path(output: Path) -> Path:
    return output.with_name(output.stem + "_scored_with.json")


def read_record(output: Path) -> dict:
    """What the scoreboard ``output`` was scored with (its ``*_scored_with.json``), or {} if none can be read."""
    path = record_path(output)
    try:
        record = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError):
        return {}
    return record if isinstance(record, dict) else {}


ARENA_HASHES = "arena_sha256"  # the record's key: each arena file's SHA-256 by the file's name


def arena_hashes(files: Iterable[str | os.PathLike]) -> dict[str, str]:
    """Each arena file's SHA-256 (:func:`aaai.files.file_sha256`) by its name, as the record of a
    scoreboard of arena files keeps them (``arena_sha256``; ``aaai eval --arenas``, ``aaai baselines
    --battery``): the scoreboard's rows name the file the same way."""
    return {Path(file).name: file_sha256(file) for file in files}


def arena_changed(file: Path, scoreboard: Path, recorded: str, now: str) -> str:
    """The head of the refusal of an arena file changed since ``scoreboard`` was scored on it."""
    return (
        f"--arenas: {str(file)!r} is not the file {str(scoreboard)!r} was scored on: "
        f"SHA-256 {recorded} recorded, {now} now"
    )


def unhashed_arenas(output: Path, record: dict | None = None) -> str | None:
    """The warning for a scoreboard of arena files whose record holds no SHA-256 of them (one written
    before they were kept, or none): a file changed since it was scored cannot be detected. ``record``
    is the one to judge (default: the one beside ``output``, if it holds rows and a record). None for
    a record that holds them."""
    if record is None:
        record = read_record(output) if _has_rows(output) else {}
        if not record:
            return None
    if ARENA_HASHES in record:
        return None
    return (
        f"warning: {str(output)!r} records no SHA-256 of its arena files (its {record_path(output).name} is "
        "missing or older than they are), so a file changed since its rows were scored cannot be detected"
    )


def check_arena_hashes(output: Path, files: Iterable[Path], record: dict | None) -> None:
    """Refuses to add to a scoreboard of arena files after one of ``files`` has changed: ConfigError
    naming the first whose SHA-256 in ``record`` (``arena_sha256``, this eval's) differs from the one
    the scoreboard's own record holds, and both hashes. Nothing to refuse for a scoreboard without
    rows, or either record without hashes."""
    hashes = (record or {}).get(ARENA_HASHES)
    if not isinstance(hashes, dict) or not _has_rows(output):
        return
    earlier = read_record(output).get(ARENA_HASHES)
    if not isinstance(earlier, dict):
        return
    for file in files:
        then, now = earlier.get(Path(file).name), hashes.get(Path(file).name)
        if then is not None and now is not None and then != now:
            raise ConfigError(
                arena_changed(Path(file), output, str(then), str(now))
                + "; rows of two versions of a file cannot share a scoreboard: score into a new --out "
                "(or put the file back as it was)"
            )


def env_record(config: Config) -> dict:
    """What a scoreboard records of the environment it was scored in: the whole environment config
    (the level and difficulty defaults aside: each row names its own), its digest, the action mode
    and the package's version."""
    from aaai import __version__

    part = {k: v for k, v in env_part(config, shaping=0.0).env_dict().items() if k not in ("level", "difficulty")}
    part = json.loads(json.dumps(part, sort_keys=True, default=str))  # as it reads back from the file
    return {
        "env_config": part,
        "env_config_sha256": config_digest(part),
        "action_mode": part.get("agent", {}).get("action_mode"),
        "aaai_version": __version__,
    }


def scoring_record(policy: Policy, record: dict | None, config: Config) -> dict:
    """The whole record of a scoreboard: the policy's (default: on listed seeds), the environment's
    and, for a policy whose actions are put on a grid, how they are computed (``numerics``)."""
    numerics = {"numerics": policy.numerics} if policy.numerics else {}
    return {**(record if record is not None else policy_record(policy, "list")), **env_record(config), **numerics}


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    if not isinstance(tree, dict):
        return {prefix: tree}
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        flat.update(_flat(value, f"{prefix}.{key}" if prefix else str(key)))
    return flat


def record_differences(earlier: Any, record: dict) -> list[str]:
    """The keys in which two records differ, each with both values (dotted for nested keys)."""
    old, new = _flat(earlier if isinstance(earlier, dict) else {}), _flat(record)
    missing = object()
    return [
        f"{key}: {old.get(key, 'absent')!r} there, {new.get(key, 'absent')!r} now"
        for key in sorted(set(old) | set(new), key=str)
        if old.get(key, missing) != new.get(key, missing)
    ]


def config_digest(part: dict) -> str:
    """The SHA-256 a record keeps of its environment config (``env_config_sha256``)."""
    return hashlib.sha256(json.dumps(part, sort_keys=True).encode()).hexdigest()


def with_added_defaults(earlier: Any, record: dict) -> Any:
    """``earlier`` (a scoreboard's record) with each environment key it does not name that ``record``
    holds at the key's default value, and its digest made again: a key added to the environment after
    the scoreboard was scored (a new sense, off by default) changed nothing its episodes saw, so it is
    no difference. A key it names, or one set to anything but its default now, is left to differ."""
    then = earlier.get("env_config") if isinstance(earlier, dict) else None
    now = record.get("env_config")
    if not (isinstance(then, dict) and isinstance(now, dict)):
        return earlier
    missing = [
        (section, key, value)
        for section, keys in now.items()
        if isinstance(keys, dict) and isinstance(then.get(section), dict)
        for key, value in keys.items()
        if key not in then[section]
    ]
    if not missing:  # the usual case: the defaults are not read
        return earlier
    default = env_record(load_config())["env_config"]
    added = [(s, k, v) for s, k, v in missing if k in default.get(s, {}) and default[s][k] == v]
    if not added:
        return earlier
    filled = {k: dict(v) if isinstance(v, dict) else v for k, v in then.items()}
    for section, key, value in added:
        filled[section][key] = value
    return {**earlier, "env_config": filled, "env_config_sha256": config_digest(filled)}


def _has_rows(output: Path) -> bool:
    try:
        with open(output, "rb") as handle:  # bytes: any file may be handed in as --out
            return sum(1 for _ in zip(range(2), handle)) > 1
    except FileNotFoundError:
        return False


def check_record(output: Path, record: dict) -> dict:
    """Refuses to add to a scoreboard scored with anything else, naming each key that differs; returns
    the record to keep with it.

    The record itself is written with the scoreboard's first row (:class:`Scoreboard`); one beside
    a scoreboard that holds no row yet (an eval that failed before its first episode ended) does
    not count. A record written before arena files' SHA-256 were kept is compared without them
    (:func:`unhashed_arenas`), and stays without them. A battery of arena files may grow (a new
    import that makes more files valid, in the same folder or another): files the scoreboard's record
    does not name yet are added to it, and the folder is the one scored now, while every file both
    name has the same SHA-256 (:func:`check_arena_hashes` refuses one that changed). An environment key
    added since it was scored, at its default value, is no difference (:func:`with_added_defaults`)."""
    path = record_path(output)
    if not _has_rows(output):
        return record
    if not path.exists():
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes of an unknown policy (no {path.name}); "
            "choose another --out, or delete it to start again"
        )
    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        earlier = None
    earlier = with_added_defaults(earlier, record)
    if isinstance(earlier, dict) and ARENA_HASHES not in earlier:  # an older scoreboard (unhashed_arenas)
        older = (ARENA_HASHES, *(() if "arenas" in earlier else ("arenas",)))  # nor, maybe, the folder
        record = {key: value for key, value in record.items() if key not in older}
    if isinstance(earlier, dict) and record.get("seeds") == "list" and earlier.get("seeds") not in (None, "list"):
        # an older scoreboard of arena files named its first call's seeds ("0-0"); its rows name theirs
        earlier = {**earlier, "seeds": "list"}
    hashed = isinstance(earlier, dict) and isinstance(earlier.get(ARENA_HASHES), dict)
    if hashed and isinstance(record.get(ARENA_HASHES), dict):
        then, now = earlier[ARENA_HASHES], record[ARENA_HASHES]
        rest = [{k: v for k, v in r.items() if k not in (ARENA_HASHES, "arenas")} for r in (earlier, record)]
        if rest[0] == rest[1] and all(now.get(name, digest) == digest for name, digest in then.items()):
            earlier = record = {**record, ARENA_HASHES: {**then, **now}}  # none changed: the battery grows
    if earlier != record:
        differences = record_differences(earlier, record) or ["its record cannot be read"]
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes scored otherwise; refusing to add episodes that "
            f"differ in {len(differences)} key(s): "
            + "; ".join(differences)
            + f". Choose another --out, or delete {output.name} and {path.name} to start again"
        )
    return record
