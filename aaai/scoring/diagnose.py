"""Why a policy fails a level: its failed scoreboard episodes replayed, and what its senses showed.

A scoreboard row says that an episode failed, not why. This replays each failed episode of a
policy (the same seed and policy give the same episode, bit for bit) and records, per decision,
what the rays showed and where the body was, to sort the failure into one first cause:

- ``fell``: the body fell (off a platform, into a hole or pit, onto deadly floor);
- ``never saw food``: no ray ever hit a piece of food the episode could still pay for;
- ``lost sight``: it saw food, then spent the last third of the episode with none in view;
- ``saw, did not reach``: food was in view late in the episode but not eaten (the body got stuck,
  circled or walked into walls);
- ``ate the wrong food``: it ate, but not enough to pass (a green before the yellows, a smaller
  green).

With a teacher (``--teacher reference``, ``search`` or ``search_strict``; gait or discrete mode), each replay is
also watched by it as DAgger's teacher watches a student drive (aaai.train.student): at every decision
it says what it would do there, and two shares of the decisions say where the student parted from it:

- ``stood while taught to move``: the student all but stood (forward under STILL_FORWARD and turn under
  STILL_TURN, in size) where its teacher asked for a walk (forward of MOVE_FORWARD or more) or a
  turn (TURN_ASKED or more);
- ``turned against``: the teacher asked for a turn of TURN_ASKED or more one way and the student turned
  at least STILL_TURN the other way.

A student that imitates well scores low on both; a student whose teacher's labels it cannot tell apart
(the same view taught both ways) learns their mean, and stands.

``aaai diagnose --policy RUN --scoreboard CSV [--levels …]`` prints the table per level; the docs'
Learned agents page quotes it. A scoreboard of arena files (``aaai eval --arenas``, ``aaai baselines
--battery``) is replayed the same way, each failed row on its arena file (found in ``--arenas DIR``,
else in the folder its ``*_scored_with.json`` names) and tabulated per category; a file missing, or
changed since it was scored (where the record holds its SHA-256), is refused before any replay; a
record that holds no SHA-256 (an older scoreboard) is replayed with a warning. The
command line replays in the environment the scoreboard's record holds (:func:`scored_config`).
"""

from __future__ import annotations

import csv
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from aaai.config import TEACHERS, Config, ConfigError, env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.files import file_sha256
from aaai.scoring.episodes import play
from aaai.scoring.policies import Policy, as_policy
from aaai.scoring.provenance import (
    ARENA_HASHES,
    arena_changed,
    env_record,
    read_record,
    record_differences,
    record_path,
    unhashed_arenas,
)
from aaai.sim.gait import as_command
from aaai.spec.kinds import KIND_INDEX
from aaai.task.arena import arena_meta, load_arena

FOOD_CHANNELS = (KIND_INDEX["food_green"], KIND_INDEX["food_yellow"])
STILL_FORWARD, STILL_TURN = 0.2, 0.3  # a student's gait command this small in both: it all but stands
MOVE_FORWARD, TURN_ASKED = 0.3, 0.5  # a teacher's forward or turn this large: it asks for a walk or a turn
RAY_WIDTH = 11  # the classic rays: nine kinds, nothing, distance
CAUSES = ("fell", "never saw food", "lost sight", "saw, did not reach", "ate the wrong food")


@dataclass(frozen=True)
class Failure:
    level: int
    difficulty: int
    seed: int
    cause: str
    seen_share: float  # decisions with food in view / decisions
    food_eaten: int
    wall_hits: int
    arena: str = ""  # the arena file's name, for a row of an arena scoreboard
    group: str = ""  # what the table groups it by: the level's label and name, or the arena's category
    stood: float | None = None  # with a teacher: decisions the student stood where it was taught to move / decisions
    against: float | None = None  # ... it turned the other way from the turn it was taught / decisions


def food_in_view(observation: dict) -> bool:
    rays = observation.get("rays")
    if rays is None:
        return False
    grid = rays if rays.ndim == 2 else rays.reshape(-1, RAY_WIDTH)  # rays_flat: one vector of rays x RAY_WIDTH
    return bool(grid[:, list(FOOD_CHANNELS)].any())


class _Watched:
    """The policy, with a teacher watching each decision (as DAgger's does, :mod:`aaai.train.student`):
    what the teacher would do there is kept beside what the policy did."""

    def __init__(self, policy, teacher, env: AnimalAIEnv):
        self.policy, self.teacher, self.env = policy, teacher, env
        self.pairs: list[tuple[np.ndarray, np.ndarray]] = []  # (the policy's action, the teacher's)

    def reset(self, seed: int) -> None:
        self.pairs = []
        self.teacher.reset(seed)
        if hasattr(self.policy, "reset"):
            self.policy.reset(seed)

    def __call__(self, observation):
        label = self.teacher(observation)
        action = self.policy(observation)
        self.teacher.student_drove(self.env.hold * self.env.control_dt)
        # as gait commands (forward, turn, crouch): a discrete choice as the command it stands for
        self.pairs.append(
            (as_command(self.env, action).astype(np.float64), as_command(self.env, label).astype(np.float64))
        )
        return action

    def shares(self) -> tuple[float, float]:
        """(stood while taught to move, turned against), each a share of the decisions."""
        if not self.pairs:
            return 0.0, 0.0
        own = np.array([a for a, _ in self.pairs])
        taught = np.array([t for _, t in self.pairs])
        still = (np.abs(own[:, 0]) < STILL_FORWARD) & (np.abs(own[:, 1]) < STILL_TURN)
        asked = (taught[:, 0] >= MOVE_FORWARD) | (np.abs(taught[:, 1]) >= TURN_ASKED)
        against = (np.abs(taught[:, 1]) >= TURN_ASKED) & (own[:, 1] * np.sign(taught[:, 1]) <= -STILL_TURN)
        return float((still & asked).mean()), float(against.mean())


def teacher_for(name: str, env: AnimalAIEnv):
    """The controller ``--teacher NAME`` watches with, on ``env`` (gait or discrete mode: it labels gait
    commands, or the choices nearest them)."""
    from aaai.task.search import teacher

    if name not in TEACHERS:
        raise ConfigError(f"--teacher: got {name!r}; allowed: {', '.join(TEACHERS)}")
    if env.gait is None:
        raise ConfigError(
            f"--teacher: the scoreboard was scored in action mode {env.config.agent.action_mode!r}; allowed: "
            "gait or discrete (a teacher's labels are gait commands or their choices, as a DAgger student's are)"
        )
    return teacher(name, env)


def replay_failure(env: AnimalAIEnv, policy, row: dict, arena: Path | None = None, teacher=None) -> Failure:
    """Replays one failed row (on ``arena``, the file of an arena row) and names its first cause; with
    ``teacher`` (a controller on ``env``), also where the policy parted from it (``stood``, ``against``)."""
    level, difficulty, seed = int(row["level"]), int(row["difficulty"]), int(row["seed"])
    seen: list[bool] = []
    watched = _Watched(policy, teacher, env) if teacher is not None else None
    if arena is None:
        options: dict = {"level": level, "difficulty": difficulty}
        group = _level_group(level)
    else:  # as aaai.scoring.episodes.run_episode plays an arena file
        options = {"spec": load_arena(arena, seed, body=env.config.agent.body), "check": False, "arena_file": True}
        group = f"category {arena_meta(arena)['category'] or 'uncategorised'}"
    result = play(
        env,
        watched or policy,
        seed,
        options=options,
        on_reset=lambda observation, info: seen.append(food_in_view(observation)),
        on_step=lambda step, observation, reward, info: seen.append(food_in_view(observation)),
    )
    info = result.info
    seen_array = np.array(seen)
    late = seen_array[len(seen_array) * 2 // 3 :]
    if info["fell"]:
        cause = "fell"
    elif info["food_eaten"] > 0:
        cause = "ate the wrong food"
    elif not seen_array.any():
        cause = "never saw food"
    elif not late.any():
        cause = "lost sight"
    else:
        cause = "saw, did not reach"
    return Failure(
        level,
        difficulty,
        seed,
        cause,
        float(seen_array.mean()),
        int(info["food_eaten"]),
        int(info["wall_hits"]),
        arena.name if arena is not None else "",
        group,
        *(watched.shares() if watched is not None else ()),
    )


def _level_group(level: int) -> str:
    from aaai.levels import get_level

    return f"{get_level(level).label} {get_level(level).name}"


def scored_config(scoreboard: Path, config: Config, given: bool) -> Config:
    """The environment to replay ``scoreboard``'s episodes in: the one its record holds (``env_config``),
    else ``config``. A ``config`` the user gave (``given``, --config) in which the environment differs
    from the record is refused (ConfigError naming the keys): its replays would not be the episodes
    scored."""
    env = read_record(scoreboard).get("env_config")
    if not isinstance(env, dict):
        return config
    if given:
        differences = record_differences(env, env_record(config)["env_config"])
        if differences:
            raise ConfigError(
                f"--config: {str(scoreboard)!r} was scored in another environment, so a replay would not be its "
                f"episodes; it differs in {len(differences)} key(s): "
                + "; ".join(differences[:4])
                + f"{'; …' if len(differences) > 4 else ''}; allowed: no --config (the scoreboard's own "
                "environment is used), or one with its values"
            )
        return config
    try:
        return load_config(env)
    except ConfigError as error:
        raise ConfigError(
            f"--config: the environment {str(record_path(scoreboard))!r} records cannot be read here ({error}); "
            "allowed: --config with the environment it was scored in"
        ) from None


def arena_sources(
    scoreboard: Path, rows: list[dict], arenas: Path | None, warn: Callable[[str], None] = print
) -> dict[str, Path]:
    """The arena file of each arena row: in ``arenas`` (a folder, or one file), else where the
    scoreboard's record (``*_scored_with.json``, key ``arenas``) says it was scored. ConfigError,
    naming the file and the row, for a folder that is not named, a file missing, or a file whose
    SHA-256 differs from the one the record holds (``arena_sha256``, as aaai eval --arenas and aaai
    baselines --battery record it); a record without them (an older scoreboard) is ``warn``-ed about:
    a changed file cannot be detected."""
    names = sorted({row["arena"] for row in rows if row.get("arena")})
    if not names:
        return {}
    record = read_record(scoreboard)
    if arenas is None:
        if not isinstance(record.get("arenas"), str):
            raise ConfigError(
                f"--arenas: {str(scoreboard)!r} holds arena rows ({names[0]}, ...) and its record names no arena "
                "folder; allowed: --arenas DIR, the folder of arena files it was scored on"
            )
        arenas = Path(record["arenas"])
    folder = arenas if arenas.is_dir() or not arenas.suffix else arenas.parent
    recorded = record.get(ARENA_HASHES)
    hashes: dict = recorded if isinstance(recorded, dict) else {}
    note = unhashed_arenas(scoreboard, record)
    if note:
        warn(note)
    sources = {}
    for name in names:
        file = folder / name
        seeds = ", ".join(sorted({row["seed"] for row in rows if row.get("arena") == name}))
        if not file.is_file():
            raise ConfigError(
                f"--arenas: {str(file)!r} is missing; the scoreboard's failed rows of {name} (seed {seeds}) were "
                f"scored on it; allowed: --arenas DIR, the folder of arena files {str(scoreboard)!r} was scored on"
            )
        now = file_sha256(file) if name in hashes else None
        if now is not None and now != hashes[name]:
            raise ConfigError(
                arena_changed(file, scoreboard, str(hashes[name]), now)
                + "; a replay would not be the episode scored; allowed: the arena files as they were scored"
            )
        sources[name] = file
    return sources


def diagnose(
    policy: Policy | str,
    scoreboard: Path,
    config: Config,
    levels: list[int] | None = None,
    limit: int | None = None,
    arenas: Path | None = None,
    warn: Callable[[str], None] = print,
    teacher: str | None = None,
) -> list[Failure]:
    """Replays the failed rows of ``scoreboard`` (of ``levels``, which leave arena rows out; at most
    ``limit`` per level or arena category) with ``policy`` (a Policy, or a --policy string); an arena
    row on its file (:func:`arena_sources`, every file checked before any replay; ``warn`` told of
    a record without their SHA-256); with ``teacher`` (one of TEACHERS) watching each replay."""
    policy = as_policy(policy)

    with open(scoreboard, newline="") as handle:
        rows = [
            r
            for r in csv.DictReader(handle)
            if r["outcome"] == "failed" and (levels is None or (not r.get("arena") and int(r["level"]) in levels))
        ]
    sources = arena_sources(scoreboard, rows, arenas, warn)
    if limit is not None:
        kept: list[dict] = []
        count: Counter[str] = Counter()
        for row in rows:
            group = f"category {arena_meta(sources[row['arena']])['category']}" if row.get("arena") else row["level"]
            if count[group] < limit:
                kept.append(row)
                count[group] += 1
        rows = kept
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        watcher = teacher_for(teacher, env) if teacher is not None else None
        acting = policy.build(env)
        return [replay_failure(env, acting, row, sources.get(row.get("arena") or ""), watcher) for row in rows]
    finally:
        env.close()


def table_markdown(failures: list[Failure]) -> str:
    """A row per level (in level order), then per arena category: the failed episodes replayed, each
    cause's count and the share of decisions with food in view; with a teacher, the shares of decisions
    the student stood where it was taught to move and turned against it (the mean over the episodes)."""
    first = "level or category" if any(f.arena for f in failures) else "level"
    taught = any(f.stood is not None for f in failures)
    extra = " stood while taught to move | turned against its teacher |" if taught else ""
    lines = [
        f"| {first} | failed episodes replayed | "
        + " | ".join(CAUSES)
        + f" | food in view (share of decisions) |{extra}",
        "|---|---:|" + "---:|" * len(CAUSES) + "---:|" + "---:|---:|" * taught,
    ]
    groups = sorted({(bool(f.arena), f.level if not f.arena else 0, f.group) for f in failures})
    for _, _, group in groups:
        mine = [f for f in failures if f.group == group]
        counts = Counter(f.cause for f in mine)
        lines.append(
            f"| {group} | {len(mine)} | "
            + " | ".join(str(counts[c]) for c in CAUSES)
            + f" | {100 * np.mean([f.seen_share for f in mine]):.0f}% |"
            + (
                f" {100 * np.mean([f.stood for f in mine]):.0f}% | {100 * np.mean([f.against for f in mine]):.0f}% |"
                if taught
                else ""
            )
        )
    return "\n".join(lines) + "\n"
