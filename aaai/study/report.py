"""``aaai study report``: humans against agents on a study's battery.

Participants' finished battery trials (read from the study's store) beside each policy's rows on
the same trials: scoreboards written by ``aaai eval --study``, and the committed baseline table's
rows (``baselines/*.csv``) for the same (level, difficulty, seed). Per trial and per level: the
pass rate (passed or succeeded) with its 95 % Wilson interval, and for participants the reaction
time to the first move (median and quartiles), the path the trunk travelled in metres (median and
quartiles; a policy's from its replays, measured the same way: :mod:`aaai.study.paths`) and the
median episode length in control steps. Written as ``report.md``, ``report.csv`` and one figure, ``report.png``.
"""

from __future__ import annotations

import csv
import io
import json
import statistics
from dataclasses import dataclass
from pathlib import Path

from aaai.errors import ConfigError
from aaai.files import atomic_path, write_atomic
from aaai.levels import get_level
from aaai.scoring.evaluation import record_path, scored_episodes
from aaai.study.store import METRES_PER_UNIT, UNFINISHED, Store, trial_of
from aaai.study.studyfile import Study, Trial
from aaai.tools.baselines import passed, wilson

HUMANS = "humans"
CSV_COLUMNS = [
    "scope",
    "name",
    "who",
    "episodes",
    "passed",
    "pass_rate",
    "low",
    "high",
    "reaction_median",
    "reaction_q1",
    "reaction_q3",
    "abandoned",
    "path_median_m",
    "path_q1_m",
    "path_q3_m",
    "steps_median",
]
Key = tuple  # (level, difficulty, seed, arena name or "")


def trial_key(trial: Trial) -> Key:
    if trial.arena is not None:
        return (None, None, trial.seed, trial.arena.name)
    return (trial.level, trial.difficulty, trial.seed, "")


def row_key(row: dict) -> Key:
    if row.get("arena"):
        return (None, None, int(row["seed"]), row["arena"])
    return (int(row["level"]), int(row["difficulty"]), int(row["seed"]), "")


def level_name(trial: Trial) -> str:
    """The group a trial is summed in: its level (L0, L2b...) or its arena file."""
    return trial.arena.name if trial.arena is not None else get_level(trial.level or 0).label


@dataclass
class Line:
    """One row of the report: a trial or level, one player (humans or a policy), its figures."""

    scope: str
    name: str
    who: str
    episodes: int
    passes: int
    reactions: list[float]
    steps: list[int]
    paths: list[float]
    abandoned: int | None = None  # attempts left unfinished (humans only)

    def csv_row(self) -> dict:
        low, high = wilson(self.passes, self.episodes) if self.episodes else (None, None)
        quartiles, paths = _quartiles(self.reactions), _quartiles(self.paths)
        return {
            "scope": self.scope,
            "name": self.name,
            "who": self.who,
            "episodes": self.episodes,
            "passed": self.passes,
            "pass_rate": _num(self.passes / self.episodes if self.episodes else None),
            "low": _num(low),
            "high": _num(high),
            "reaction_median": _num(quartiles[1]),
            "reaction_q1": _num(quartiles[0]),
            "reaction_q3": _num(quartiles[2]),
            "abandoned": "" if self.abandoned is None else self.abandoned,
            "path_median_m": _num(paths[1]),
            "path_q1_m": _num(paths[0]),
            "path_q3_m": _num(paths[2]),
            "steps_median": _num(statistics.median(self.steps) if self.steps else None),
        }


def _num(value: float | None) -> str:
    return "" if value is None else f"{value:.4g}"


def _quartiles(values: list[float]) -> tuple[float | None, float | None, float | None]:
    if not values:
        return None, None, None
    if len(values) == 1:
        return values[0], values[0], values[0]
    q1, median, q3 = statistics.quantiles(values, n=4, method="inclusive")
    return q1, median, q3


def _spread(values: list[float], digits: int) -> str:
    """'median (q1-q3)', or '-' with no values."""
    q1, median, q3 = _quartiles(values)
    if median is None or q1 is None or q3 is None:
        return "-"
    return f"{median:.{digits}f} ({q1:.{digits}f}-{q3:.{digits}f})"


def human_rows(store: Store) -> list[dict]:
    """The participants' finished battery trials: each its scoreboard row, ``reaction_time``,
    ``path_m`` and ``participant``."""
    rows = []
    for trial in store.trials():
        if trial["kind"] != "battery" or trial["finished"] is None or not trial["row"]:
            continue
        rows.append(
            {
                **json.loads(trial["row"]),
                "reaction_time": trial["reaction_time"],
                "path_m": trial.get("path_m"),
                "participant": trial["participant"],
            }
        )
    return rows


def policy_boards(paths: list[Path]) -> dict[str, list[dict]]:
    """Scoreboards by policy name (their ``_scored_with.json``'s, else the file's stem)."""
    boards: dict[str, list[dict]] = {}
    for path in paths:
        if not path.is_file():
            raise ConfigError(
                f"--policy-scores: {str(path)!r} does not exist; allowed: a scoreboard `aaai eval --study` wrote"
            )
        name = path.stem
        record = record_path(path)
        if record.is_file():
            try:
                name = str(json.loads(record.read_text()).get("policy") or name)
            except (ValueError, AttributeError):
                pass
        if name in boards:
            name = f"{name} ({path.stem})"
        boards[name] = scored_episodes(path)
    return boards


def baseline_boards(folder: Path, keys: set[Key]) -> dict[str, list[dict]]:
    """The baseline table's rows (``folder/*.csv``) on the study's trials, by ``baseline:NAME``;
    tables with none of them left out."""
    if not folder.is_dir():
        raise ConfigError(
            f"--baselines: {str(folder)!r} is not a folder; allowed: the baseline table's folder (baselines/)"
        )
    boards = {}
    for path in sorted(folder.glob("*.csv")):
        rows = [row for row in scored_episodes(path) if row_key(row) in keys]
        if rows:
            boards[f"baseline:{path.stem}"] = rows
    return boards


def replay_key(replay: dict) -> Key:
    if replay.get("arena"):
        return (None, None, int(replay["seed"]), replay["arena"]["name"])
    return (int(replay["level"]), int(replay["difficulty"]), int(replay["seed"]), "")


def attach_replay_paths(boards: dict[str, list[dict]], folders: list[Path], keys: set[Key]) -> None:
    """Each policy row's ``path_m``, measured from its replay (``aaai eval --study --save-replays
    DIR``) as a participant's is: a replay of a policy with a scoreboard here, on a study trial."""
    from aaai.scoring.replays import load_replay
    from aaai.study.paths import replay_path

    for folder in folders:
        if not folder.is_dir():
            raise ConfigError(
                f"--policy-replays: {str(folder)!r} is not a folder; allowed: the folder of "
                "`aaai eval --study STUDY_FILE --save-replays DIR`"
            )
        used = 0
        for path in sorted(folder.glob("*.json")):
            replay = load_replay(path)
            who, key = replay.get("policy"), replay_key(replay)
            if who not in boards or key not in keys:
                continue
            rows = [row for row in boards[who] if row_key(row) == key and row.get("path_m") in (None, "")]
            if rows:
                rows[0]["path_m"] = replay_path(replay, f"--policy-replays: {str(path)!r}")
                used += 1
        if not used:
            raise ConfigError(
                f"--policy-replays: {str(folder)!r} holds no replay of a --policy-scores policy on the study's "
                f"trials (policies: {', '.join(sorted(boards)) or 'none'}); allowed: the replays "
                "`aaai eval --study STUDY_FILE --save-replays DIR` wrote beside that scoreboard"
            )


def abandoned_attempts(store: Store) -> dict[Key, int]:
    """Battery trials' attempts left unfinished (abandoned or interrupted), by trial."""
    counts: dict[Key, int] = {}
    for attempt in store.attempts():
        if attempt["kind"] == "battery" and attempt["state"] in UNFINISHED:
            key = trial_key(trial_of(attempt))
            counts[key] = counts.get(key, 0) + 1
    return counts


def lines_for(
    study: Study, humans: list[dict], boards: dict[str, list[dict]], abandoned: dict[Key, int] | None = None
) -> list[Line]:
    """Per trial (in the battery's order), then per level: a line for the humans and one per policy."""
    players = {HUMANS: humans, **boards}
    by_key: dict[str, dict[Key, list[dict]]] = {}
    for who, rows in players.items():
        for row in rows:
            by_key.setdefault(who, {}).setdefault(row_key(row), []).append(row)
    groups: list[tuple[str, str, list[Key]]] = []
    for trial in study.battery:
        groups.append(("trial", trial.label(), [trial_key(trial)]))
    levels: dict[str, list[Key]] = {}
    for trial in study.battery:
        levels.setdefault(level_name(trial), []).append(trial_key(trial))
    groups += [("level", name, keys) for name, keys in levels.items()]
    groups.append(("level", "all", [trial_key(t) for t in study.battery]))
    lines = []
    for scope, name, keys in groups:
        for who in players:
            rows = [row for key in dict.fromkeys(keys) for row in by_key.get(who, {}).get(key, [])]
            lines.append(
                Line(
                    scope,
                    name,
                    who,
                    len(rows),
                    sum(map(passed, rows)),
                    [float(r["reaction_time"]) for r in rows if r.get("reaction_time") not in (None, "")],
                    [int(r["steps"]) for r in rows],
                    [float(r["path_m"]) for r in rows if r.get("path_m") not in (None, "")],
                    sum((abandoned or {}).get(key, 0) for key in dict.fromkeys(keys)) if who == HUMANS else None,
                )
            )
    return lines


def report_csv(lines: list[Line]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for line in lines:
        writer.writerow(line.csv_row())
    return buffer.getvalue()


def report_markdown(study: Study, lines: list[Line], participants: int) -> str:
    """Two tables, per trial and per level, a row for each player with episodes there: pass rate,
    its 95 % Wilson interval, passed/episodes, reaction time (humans) and median steps."""
    parts = [
        f"# {study.name}: humans against agents\n",
        f"{participants} participant{'s' * (participants != 1)}; pass rate = passed or succeeded, with its "
        "95 % Wilson interval and passed/episodes; abandoned: attempts left unfinished (the tab closed, "
        "the server stopped), each played again; reaction time to the first move in seconds and the "
        f"path the body's trunk travelled in metres (1 world unit = {METRES_PER_UNIT:g} m), median (quartiles); "
        "episode length in control steps (median).\n",
    ]
    for scope, title in (("trial", "Per trial"), ("level", "Per level")):
        table = [
            f"## {title}\n",
            f"| {scope} | player | pass rate | 95 % interval | passed | abandoned | reaction s | path m | steps |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for line in lines:
            if line.scope != scope or not line.episodes:
                continue
            low, high = wilson(line.passes, line.episodes)
            table.append(
                f"| {line.name} | {line.who} | {100 * line.passes / line.episodes:.0f}% | "
                f"{100 * low:.0f}-{100 * high:.0f}% | {line.passes}/{line.episodes} | "
                f"{'-' if line.abandoned is None else line.abandoned} | {_spread(line.reactions, 2)} | "
                f"{_spread(line.paths, 1)} | {statistics.median(line.steps):g} |"
            )
        parts.append("\n".join(table) + "\n")
    return "\n".join(parts)


def write_figure(lines: list[Line], path: Path) -> None:
    """Pass rate per level (and all), humans beside each policy, with 95 % Wilson interval bars."""
    try:
        import matplotlib
    except ImportError:
        raise ImportError("the report's figure needs matplotlib (the train extra: pip install -e '.[train]')") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    levels = [line for line in lines if line.scope == "level"]
    names = list(dict.fromkeys(line.name for line in levels))
    players = list(dict.fromkeys(line.who for line in levels))
    width = 0.8 / len(players)
    figure, axes = plt.subplots(figsize=(max(4.0, 1.2 * len(names) * len(players) ** 0.5 + 2), 3.2))
    for index, who in enumerate(players):
        xs, rates, below, above = [], [], [], []
        for position, name in enumerate(names):
            line = next(item for item in levels if item.name == name and item.who == who)
            if not line.episodes:
                continue
            rate = line.passes / line.episodes
            low, high = wilson(line.passes, line.episodes)
            xs.append(position + (index - (len(players) - 1) / 2) * width)
            rates.append(rate)
            below.append(rate - low)
            above.append(high - rate)
        axes.bar(xs, rates, width, yerr=[below, above], capsize=3, label=who)
    axes.set_xticks(range(len(names)), names)
    axes.set_ylim(0, 1.05)
    axes.set_ylabel("pass rate (95 % Wilson)")
    axes.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
    figure.tight_layout()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", dpi=110)
    plt.close(figure)


def write_report(
    study: Study,
    store: Store,
    out: str | Path,
    scores: list[Path] | None = None,
    baselines: Path | None = None,
    replays: list[Path] | None = None,
) -> list[Path]:
    """Writes ``out/report.md``, ``out/report.csv`` and ``out/report.png``; their paths."""
    out = Path(out)
    humans = human_rows(store)
    keys = {trial_key(t) for t in study.battery}
    boards = policy_boards(list(scores or []))
    for name, rows in boards.items():
        if not any(row_key(row) in keys for row in rows):
            raise ConfigError(
                f"--policy-scores: the scoreboard of {name!r} holds none of study {study.name!r}'s trials; "
                "allowed: a scoreboard `aaai eval --study` wrote for this study"
            )
    if replays:
        attach_replay_paths(boards, list(replays), keys)
    if baselines is not None:
        boards.update(baseline_boards(Path(baselines), keys))
    lines = lines_for(study, humans, boards, abandoned_attempts(store))
    participants = len({row["participant"] for row in humans})
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "report.md", out / "report.csv", out / "report.png"]
    write_atomic(paths[0], report_markdown(study, lines, participants))
    write_atomic(paths[1], report_csv(lines))
    write_figure(lines, paths[2])
    return paths


__all__ = ["CSV_COLUMNS", "human_rows", "lines_for", "report_csv", "report_markdown", "write_figure", "write_report"]
