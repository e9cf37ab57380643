"""Replays: one episode as data (JSON), to run again bit for bit or to film.

A replay holds what decides an episode: the level (id, difficulty, seed; or an arena file, by
path and content hash), the environment's configuration (and its digest), and the action given
at every ``env.step``, run-length encoded. The same configuration, seed and actions give the same
trajectory bit for bit (docs, Determinism), so ``run_replay`` checks that the episode ends as
recorded: the same number of steps, the same return and the same final head pose, compared
exactly. A replay is data, never code: nothing in it is imported or evaluated.

``Recorder`` wraps any policy to record its episodes; ``ReplaySaver`` gives ``evaluate`` a
recorder and writes each scored episode's replay (``aaai eval --save-replays``, ``aaai play``).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from aaai.config import ConfigError
from aaai.files import file_sha256, write_atomic
from aaai.levels import get_level

FORMAT = "aaai-replay"
VERSION = 1
MAX_REPLAY_BYTES = 256 << 20  # a 10 000-step episode of 16 joint actions is a few MB
MAX_STEPS = 10_000  # the longest episode a configuration allows (episode.max_steps)
KEYS = (
    "format",
    "version",
    "policy",
    "level",
    "level_name",
    "difficulty",
    "seed",
    "arena",
    "spec_digest",
    "config",
    "config_digest",
    "steps",
    "return",
    "final_pose",
    "end",
    "actions",
)


def config_digest(config: dict) -> str:
    """SHA-256 of a configuration as canonical JSON (sorted keys): equal configs, equal digests."""
    return hashlib.sha256(json.dumps(config, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def env_config(env) -> dict:
    """The environment's own part of its resolved configuration (no training sections)."""
    return env.unwrapped.config.env_dict()


def encode_actions(actions: list[list[float]]) -> list[list]:
    """[a, a, a, b] -> [[3, a], [1, b]]: a held key gives one entry, not one per step."""
    runs: list[list] = []
    for action in actions:
        if runs and runs[-1][1] == action:
            runs[-1][0] += 1
        else:
            runs.append([1, action])
    return runs


def decode_actions(runs: list[list]) -> list[list[float]]:
    return [action for count, action in runs for _ in range(count)]


class Recorder:
    """A policy that records another: the actions it gives (exactly as ``env.step`` gets them) and,
    when the episode ends (``end_episode``), the episode as a replay (``last``)."""

    def __init__(self, env, policy: Callable, name: str):
        self.env, self.policy, self.name = env.unwrapped, policy, name
        self.actions: list[list[float]] = []
        self.last: dict | None = None

    def reset(self, seed: int) -> None:
        self.actions, self.last = [], None
        if hasattr(self.policy, "reset"):
            self.policy.reset(seed)

    def __call__(self, observation):
        action = self.policy(observation)
        self.actions.append([float(v) for v in np.asarray(action, dtype=np.float64).ravel()])
        return action

    def snapshot(self, episode_return: float, steps: int, end: str | None) -> dict:
        """The episode so far as a replay (without its arena file, which ``with_arena`` adds)."""
        env = self.env
        spec, head = env.level_spec, env.snapshot().head
        config = env_config(env)
        return {
            "format": FORMAT,
            "version": VERSION,
            "policy": self.name,
            "level": spec.level,
            "level_name": spec.name,
            "difficulty": spec.difficulty,
            "seed": spec.seed,
            "arena": None,
            "spec_digest": spec.digest(),
            "config": config,
            "config_digest": config_digest(config),
            "steps": steps,
            "return": episode_return,
            "final_pose": {"x": head.x, "y": head.y, "z": head.z, "yaw": head.yaw},
            "end": end,
            "actions": encode_actions(self.actions),
        }

    def end_episode(self, result) -> None:
        self.last = self.snapshot(result.episode_return, result.steps, result.end)
        if hasattr(self.policy, "end_episode"):
            self.policy.end_episode(result)


def with_arena(replay: dict, arena: str | Path | None) -> dict:
    """The replay naming the arena file it was played on (its path and content hash)."""
    if arena is None:
        return replay
    return {
        **replay,
        "arena": {"name": Path(arena).name, "path": str(Path(arena).resolve()), "sha256": file_sha256(arena)},
    }


def replay_name(replay: dict, prefix: str = "") -> str:
    """A file name for a replay: [prefix_]<label>_d<D>_s<S>.json, or <arena stem>_s<S>.json."""
    if replay["arena"]:
        stem = f"{Path(replay['arena']['name']).stem}_s{replay['seed']}"
    else:
        stem = f"{get_level(replay['level']).label}_d{replay['difficulty']}_s{replay['seed']}"
    stem = f"{prefix}_{stem}" if prefix else stem
    return re.sub(r"[^A-Za-z0-9_.-]", "_", stem) + ".json"


def write_replay(replay: dict, path: str | Path) -> Path:
    path = Path(path)
    write_atomic(path, json.dumps(replay, separators=(",", ":")) + "\n")
    return path


class ReplaySaver:
    """``make_policy`` and ``on_episode`` for ``aaai.scoring.evaluation.evaluate``: the policy ``load(env)``
    gives, recorded, and each scored episode's replay written into ``folder`` as it ends."""

    def __init__(
        self,
        folder: str | Path,
        name: str,
        load: Callable,
        prefix: str = "",
        arenas: dict[str, Path] | None = None,
        on_episode: Callable[[dict], None] | None = None,
    ):
        self.folder, self.name, self.load, self.prefix = Path(folder), name, load, prefix
        self.arenas, self.then = arenas or {}, on_episode
        self.recorder: Recorder | None = None
        self.written: list[Path] = []

    def make_policy(self, env) -> Recorder:
        self.recorder = Recorder(env, self.load(env), self.name)
        return self.recorder

    def on_episode(self, row: dict) -> None:
        recorder = self.recorder
        if recorder is None or recorder.last is None:  # make_policy and the episode's end come before its row
            raise RuntimeError(f"the row of seed {row.get('seed')} came before its episode was recorded")
        replay = with_arena(recorder.last, self.arenas.get(row.get("arena") or ""))
        self.folder.mkdir(parents=True, exist_ok=True)
        self.written.append(write_replay(replay, self.folder / replay_name(replay, self.prefix)))
        if self.then is not None:
            self.then(row)


# --- reading and running ----------------------------------------------------------------
def _fail(path, key: str, value: Any, allowed: str) -> ConfigError:
    shown = repr(value)
    shown = shown if len(shown) <= 80 else shown[:77] + "..."
    return ConfigError(f"replay {str(path)!r}: key '{key}': got {shown}; allowed: {allowed}")


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def load_replay(path: str | Path) -> dict:
    """A replay file, checked: the format, every key's type, the config against its digest."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"replay {str(path)!r} does not exist (or is not a file)")
    if path.stat().st_size > MAX_REPLAY_BYTES:
        raise ConfigError(f"replay {str(path)!r}: {path.stat().st_size} bytes; allowed: at most {MAX_REPLAY_BYTES}")
    try:
        data = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise ConfigError(f"replay {str(path)!r} is not valid JSON: {error}") from None
    except RecursionError:
        raise ConfigError(f"replay {str(path)!r} nests too deeply; allowed: a replay's own shape") from None
    try:
        json.dumps(data, ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError:
        raise ConfigError(
            f"replay {str(path)!r} holds a lone surrogate (\\ud800 ...); allowed: text as UTF-8"
        ) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ConfigError(f'replay {str(path)!r} is not an aaai replay (no "format": "{FORMAT}")')
    if data.get("version") != VERSION:
        raise _fail(path, "version", data.get("version"), f"{VERSION}")
    missing = [key for key in KEYS if key not in data]
    if missing:
        raise ConfigError(f"replay {str(path)!r}: key '{missing[0]}' is missing; a replay has {', '.join(KEYS)}")
    for key in ("level", "difficulty", "seed", "steps"):
        if not isinstance(data[key], int) or isinstance(data[key], bool) or data[key] < 0:
            raise _fail(path, key, data[key], "an integer, 0 or more")
    if data["steps"] > MAX_STEPS:
        raise _fail(path, "steps", data["steps"], f"at most {MAX_STEPS:,}, the longest episode")
    for key in ("policy", "level_name", "spec_digest", "config_digest"):
        if not isinstance(data[key], str):
            raise _fail(path, key, data[key], "text")
    if data["end"] is not None and not isinstance(data["end"], str):
        raise _fail(path, "end", data["end"], "null or text")
    if not _number(data["return"]):
        raise _fail(path, "return", data["return"], "a finite number")
    pose = data["final_pose"]
    if not isinstance(pose, dict) or sorted(pose) != ["x", "y", "yaw", "z"] or not all(map(_number, pose.values())):
        raise _fail(path, "final_pose", pose, "{x, y, z, yaw}: finite numbers")
    if not isinstance(data["config"], dict) or config_digest(data["config"]) != data["config_digest"]:
        raise _fail(
            path, "config_digest", data["config_digest"], "the SHA-256 of the replay's config (the file was edited)"
        )
    arena = data["arena"]
    if arena is not None and not (
        isinstance(arena, dict) and all(isinstance(arena.get(k), str) for k in ("name", "path", "sha256"))
    ):
        raise _fail(path, "arena", arena, "null or {name, path, sha256}")
    runs = data["actions"]
    ok = isinstance(runs, list) and all(
        isinstance(run, list)
        and len(run) == 2
        and isinstance(run[0], int)
        and not isinstance(run[0], bool)
        and run[0] > 0
        and isinstance(run[1], list)
        and all(map(_number, run[1]))
        for run in runs
    )
    if not ok:
        raise _fail(path, "actions", runs, "a list of [count, [numbers]] runs")
    if sum(run[0] for run in runs) != data["steps"]:
        raise _fail(path, "steps", data["steps"], f"the number of actions, {sum(run[0] for run in runs)}")
    return data


class ReplayPolicy:
    """Gives a replay's actions in order (float64, as recorded)."""

    def __init__(self, replay: dict):
        self.actions = [np.array(action, dtype=np.float64) for action in decode_actions(replay["actions"])]
        self.index = 0

    def reset(self, seed: int) -> None:
        self.index = 0

    def __call__(self, observation):
        action = self.actions[self.index]
        self.index += 1
        return action


def replay_options(replay: dict, arena: str | Path | None = None) -> dict:
    """The reset options that build the replay's level: its cell, or its arena file loaded with its
    seed (``arena`` overrides the recorded path; the file must still hash as recorded)."""
    if replay["arena"] is None:
        return {"level": replay["level"], "difficulty": replay["difficulty"]}
    from aaai.task.arena import load_arena

    path = Path(arena) if arena is not None else Path(replay["arena"]["path"])
    if not path.is_file():
        raise ConfigError(f"replay: arena file {str(path)!r} does not exist; pass its path (--arena)")
    if file_sha256(path) != replay["arena"]["sha256"]:
        raise ConfigError(
            f"replay: arena file {str(path)!r} has changed since the episode was recorded "
            f"(SHA-256 {file_sha256(path)[:12]}..., recorded {replay['arena']['sha256'][:12]}...)"
        )
    body = ((replay.get("config") or {}).get("agent") or {}).get("body", "quadruped")  # checked for its footprint
    return {"spec": load_arena(path, replay["seed"], body=body), "check": False, "arena_file": True}


@dataclass(frozen=True)
class ReplayResult:
    result: Any  # the EpisodeResult
    final_pose: dict
    differences: list[str]  # what did not come out as recorded (empty: bit for bit)


def make_env(replay: dict, **overrides):
    """An environment with the replay's configuration (``overrides``, e.g. camera=True, change only
    what it senses)."""
    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(config=replay["config"], **overrides)
    try:
        check_actions(replay, env)
    except ConfigError:
        env.close()
        raise
    return env


def check_actions(replay: dict, env) -> None:
    """Every recorded action has as many numbers as the environment's actions, or a ConfigError."""
    width = int(np.prod(env.action_space.shape))
    for count, action in replay["actions"]:
        if len(action) != width:
            raise ConfigError(
                f"replay: an action has {len(action)} numbers; allowed: {width}, as the replay's config "
                f"({replay['config'].get('agent', {}).get('body')!r}, {env.unwrapped.action_mode!r}) acts"
            )


def run_replay(replay: dict, env=None, arena: str | Path | None = None, on_reset=None, on_step=None) -> ReplayResult:
    """Runs the replay's actions in ``env`` (default: a new one with its configuration) and compares
    the end with the recording: steps, return and final pose, exactly."""
    from aaai.scoring.episodes import play

    own = env is None
    env = make_env(replay) if own else env
    if not own:
        check_actions(replay, env)
    try:
        options = replay_options(replay, arena)
        policy = ReplayPolicy(replay)
        result = play(
            env, policy, replay["seed"], options=options, on_reset=on_reset, on_step=on_step, max_steps=replay["steps"]
        )
        spec = env.unwrapped.level_spec
        head = env.unwrapped.snapshot().head
    finally:
        if own:
            env.close()
    pose = {"x": head.x, "y": head.y, "z": head.z, "yaw": head.yaw}
    differences = []
    if spec.digest() != replay["spec_digest"]:
        differences.append(
            f"the level differs from the recorded one (spec hash {spec.digest()[:12]}..., recorded "
            f"{replay['spec_digest'][:12]}...): the level's code or parameters have changed"
        )
    if result.end != replay["end"]:
        differences.append(f"the episode ended {result.end!r} at step {result.steps}, recorded {replay['end']!r}")
    if result.episode_return != replay["return"]:
        differences.append(f"return {result.episode_return!r}, recorded {replay['return']!r}")
    if pose != replay["final_pose"]:
        differences.append(f"final pose {pose}, recorded {replay['final_pose']}")
    return ReplayResult(result, pose, differences)
