"""What a scoreboard was scored with (its provenance): the policy's record, the seeds, the
environment's config and digest, the action mode, the package version and the numerics, kept as
``*_scored_with.json`` beside the CSV; an eval that resumes a scoreboard scored otherwise is refused,
naming each key that differs."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from aaai.config import Config, ConfigError, env_part
from aaai.levels.seeds import key_record
from aaai.scoring.policies import Policy, as_policy


def policy_record(policy: Policy | str, seeds: str, key: str | None = None) -> dict:
    """What a scoreboard was scored with: the policy's record (its model file and hash, or its
    source's hash), the seeds and the seed key's record. An eval that resumes a scoreboard must match it."""
    return {**as_policy(policy).record, "seeds": seeds, "seed_key": key_record(key)}


def record_path(output: Path) -> Path:
    return output.with_name(output.stem + "_scored_with.json")


def env_record(config: Config) -> dict:
    """What a scoreboard records of the environment it was scored in: the whole environment config
    (the level and difficulty defaults aside: each row names its own), its digest, the action mode
    and the package's version."""
    from aaai import __version__

    part = {k: v for k, v in env_part(config, shaping=0.0).env_dict().items() if k not in ("level", "difficulty")}
    part = json.loads(json.dumps(part, sort_keys=True, default=str))  # as it reads back from the file
    digest = hashlib.sha256(json.dumps(part, sort_keys=True).encode()).hexdigest()
    return {
        "env_config": part,
        "env_config_sha256": digest,
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


def _has_rows(output: Path) -> bool:
    try:
        with open(output, "rb") as handle:  # bytes: any file may be handed in as --out
            return sum(1 for _ in zip(range(2), handle)) > 1
    except FileNotFoundError:
        return False


def check_record(output: Path, record: dict) -> None:
    """Refuses to add to a scoreboard scored with anything else, naming each key that differs.

    The record itself is written with the scoreboard's first row (:class:`Scoreboard`); one beside
    a scoreboard that holds no row yet (an eval that failed before its first episode ended) does
    not count."""
    path = record_path(output)
    if not _has_rows(output):
        return
    if not path.exists():
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes of an unknown policy (no {path.name}); "
            "choose another --out, or delete it to start again"
        )
    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        earlier = None
    if earlier != record:
        differences = record_differences(earlier, record) or ["its record cannot be read"]
        raise ConfigError(
            f"--out: {str(output)!r} holds episodes scored otherwise; refusing to add episodes that "
            f"differ in {len(differences)} key(s): "
            + "; ".join(differences)
            + f". Choose another --out, or delete {output.name} and {path.name} to start again"
        )
