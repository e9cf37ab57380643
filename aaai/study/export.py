"""``aaai study export``: a study's finished trials from its store, as a scoreboard CSV and replays.

The CSV has one row per finished trial: the policy ``human:ID``, the participant, the trial's
position in that participant's order and its kind (practice or battery), the scoreboard's own
columns (``aaai eval``'s), the reaction time to the first move, the path the body's trunk travelled
in metres (``path_m``) and the trial's start and end times (UTC). Each replay is a file ``aaai
show --replay`` and ``aaai run --replay`` play back. ``attempts.csv`` has one row per attempt at a
trial (its clock started): finished, abandoned (tab closed, server stopped; the reason), interrupted
(the server died) or still playing, with when it started and ended and how far it got.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from aaai.files import write_atomic
from aaai.scoring.evaluation import COLUMNS
from aaai.scoring.replays import replay_name, write_replay
from aaai.study.store import Store

EXPORT_COLUMNS = [
    "policy",
    "participant",
    "position",
    "kind",
    *COLUMNS,
    "reaction_time",
    "path_m",
    "started",
    "finished",
]

ATTEMPT_COLUMNS = [
    "participant",
    "position",
    "kind",
    "level",
    "difficulty",
    "seed",
    "arena",
    "attempt",
    "state",
    "reason",
    "started",
    "ended",
    "steps",
    "seconds",
    "food_eaten",
    "path_m",
]


def attempts_csv(store: Store) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, ATTEMPT_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for attempt in store.attempts():
        arena = attempt["arena"]
        writer.writerow(
            {
                **{key: "" if value is None else value for key, value in attempt.items()},
                "arena": Path(arena).name if arena else "",
            }
        )
    return buffer.getvalue()


def export(store: Store, out: str | Path) -> tuple[Path, list[Path]]:
    """Writes ``out/scores.csv``, ``out/attempts.csv`` and ``out/replays/*.json`` (each file
    atomically); the scores' and the replays' paths."""
    out = Path(out)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, EXPORT_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    replays: list[Path] = []
    for trial in store.trials():
        if trial["finished"] is None:
            continue
        pid = trial["participant"]
        row = json.loads(trial["row"])
        reaction, path = trial["reaction_time"], trial.get("path_m")
        writer.writerow(
            {
                **row,
                "policy": f"human:{pid}",
                "participant": pid,
                "position": trial["position"],
                "kind": trial["kind"],
                "reaction_time": "" if reaction is None else reaction,
                "path_m": "" if path is None else path,
                "started": trial["started"] or "",
                "finished": trial["finished"],
            }
        )
        replay = json.loads(trial["replay"])
        replays.append(write_replay(replay, out / "replays" / replay_name(replay, f"{pid}_{trial['position']:03d}")))
    scores = out / "scores.csv"
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(scores, buffer.getvalue())
    write_atomic(out / "attempts.csv", attempts_csv(store))
    return scores, replays


__all__ = ["ATTEMPT_COLUMNS", "EXPORT_COLUMNS", "attempts_csv", "export"]
