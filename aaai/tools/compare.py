"""`aaai compare`: two scoreboards of the same reserved episodes, level by level: each one's pass
rate with its 95 % Wilson interval (as the baseline table gives it), and the difference with its 95 %
interval (Newcombe's hybrid score interval, built from the two Wilson intervals).

The episodes compared are those both scoreboards hold (the same level, difficulty and seed), so a
scoreboard still being scored is compared on what it has. The interval of the difference treats the
two pass rates as independent; both policies played the same seeds, so where their outcomes go
together the interval is wider than a paired one would be (it errs towards "no difference shown").
The pairing is used by the last columns: the episodes only one of the two passed, and McNemar's exact
test on them.

Those intervals count the episodes' chance only: they say whether two *models* differ. Whether two
*recipes* (a config trained with any seed) differ needs several training runs of each, since one run
of a recipe moves a student by several points overall and tens on a level. :func:`compare_runs` takes
each side's runs, and per level gives every run's pass rate and the difference of the two sides'
means with Welch's 95 % t interval over the runs (each run's pass rate one value, so the interval
counts the training's chance and the episodes' alike). Where every run of each side passes the same
count, the runs give no spread to build that interval from, and the episodes' Newcombe interval is
given instead (marked in the table).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from aaai.config import ConfigError
from aaai.levels import get_level
from aaai.tools.baselines import passed, wilson

NEEDED = ("level", "difficulty", "seed", "outcome")
WEAKEST = 4  # the baseline's weakest levels, marked in the table and counted in its last line


@dataclass(frozen=True)
class Rate:
    """A pass rate: passes of episodes, with its 95 % Wilson interval (fractions)."""

    passes: int
    episodes: int

    @property
    def value(self) -> float:
        return self.passes / self.episodes

    @property
    def interval(self) -> tuple[float, float]:
        return wilson(self.passes, self.episodes)

    def text(self) -> str:
        low, high = self.interval
        return f"{100 * self.value:.0f}% ({100 * low:.0f}-{100 * high:.0f})"


@dataclass(frozen=True)
class LevelComparison:
    """One level (``level`` None: all levels): the two pass rates on the same episodes, the
    difference ``other - base`` with its 95 % interval (fractions), and the episodes only ``other``
    passed (``gained``) and only ``base`` passed (``lost``), for the paired test."""

    level: int | None
    base: Rate
    other: Rate
    gained: int = 0
    lost: int = 0

    @property
    def paired_p(self) -> float:
        """McNemar's exact test on the episodes where the two differ: the two-sided binomial p of
        ``gained`` against ``lost`` at one half each (1 when none differ)."""
        return mcnemar(self.gained, self.lost)

    @property
    def difference(self) -> float:
        return self.other.value - self.base.value

    @property
    def interval(self) -> tuple[float, float]:
        return newcombe(self.base, self.other)

    @property
    def verdict(self) -> str:
        return verdict(self.interval)


def verdict(interval: tuple[float, float]) -> str:
    """What an interval of a difference ``other - base`` says: better (above 0), worse (below 0), or
    no difference shown."""
    low, high = interval
    return "better" if low > 0 else "worse" if high < 0 else "no difference shown"


def by_level(common: list[tuple[int, int, int]]):
    """(level, its episodes) for each level of ``common`` in order, then (None, all of them)."""
    for level in sorted({key[0] for key in common}) + [None]:
        yield level, [key for key in common if level is None or key[0] == level]


def newcombe(base: Rate, other: Rate) -> tuple[float, float]:
    """Newcombe's hybrid score interval (1998, method 10) of ``other - base``: 95 %, from the Wilson
    intervals of the two rates."""
    (low_a, high_a), (low_b, high_b) = base.interval, other.interval
    a, b = base.value, other.value
    return (
        b - a - math.sqrt((b - low_b) ** 2 + (high_a - a) ** 2),
        b - a + math.sqrt((high_b - b) ** 2 + (a - low_a) ** 2),
    )


def mcnemar(gained: int, lost: int) -> float:
    """McNemar's exact two-sided p: the chance, at one half each, of a split of ``gained + lost``
    discordant episodes at least as uneven as this one."""
    n, k = gained + lost, min(gained, lost)
    if n == 0:
        return 1.0
    return min(1.0, 2 * sum(math.comb(n, i) for i in range(k + 1)) / 2**n)


def read_scoreboard(path: str | Path) -> list[dict]:
    """A scoreboard CSV's rows (``aaai eval --out``), refused with one message naming the file when it
    is not a scoreboard of level cells."""
    path = Path(path)
    try:
        with open(path, newline="") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            columns = reader.fieldnames or []
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise ConfigError(f"scoreboard {str(path)!r}: cannot be read ({error})") from None
    missing = [column for column in NEEDED if column not in columns]
    if missing:
        raise ConfigError(
            f"scoreboard {str(path)!r}: has no column {missing[0]!r}; allowed: a scoreboard CSV of aaai eval"
        )
    if any(row.get("arena") for row in rows):
        raise ConfigError(
            f"scoreboard {str(path)!r}: holds arena files' episodes; allowed: a scoreboard of level cells (aaai eval)"
        )
    try:
        for row in rows:
            int(row["level"]), int(row["difficulty"]), int(row["seed"])
    except (TypeError, ValueError):
        raise ConfigError(
            f"scoreboard {str(path)!r}: a row's level, difficulty or seed is not a whole number"
        ) from None
    return rows


def board_name(path: str | Path) -> str:
    """A scoreboard's name in the table: its file's name, or for a run's ``scoreboard_*.csv`` its run
    folder's (``runs/student_ppo/scoreboard_reserved.csv``: student_ppo)."""
    path = Path(path)
    return path.parent.name if path.stem.startswith("scoreboard") and path.parent.name else path.stem


def _key(row: dict) -> tuple[int, int, int]:
    return int(row["level"]), int(row["difficulty"]), int(row["seed"])


def compare(base: list[dict], other: list[dict]) -> list[LevelComparison]:
    """Per level, then all levels: the pass rates of ``base`` and ``other`` on the episodes both hold
    (by level, difficulty and seed; a seed scored twice on one board counts once, its last row)."""
    ours, theirs = {_key(r): passed(r) for r in base}, {_key(r): passed(r) for r in other}
    common = sorted(set(ours) & set(theirs))
    if not common:
        raise ConfigError("compare: the two scoreboards share no episode (level, difficulty and seed)")
    lines = []
    for level, keys in by_level(common):
        lines.append(
            LevelComparison(
                level,
                Rate(sum(ours[key] for key in keys), len(keys)),
                Rate(sum(theirs[key] for key in keys), len(keys)),
                gained=sum(theirs[key] and not ours[key] for key in keys),
                lost=sum(ours[key] and not theirs[key] for key in keys),
            )
        )
    return lines


@dataclass(frozen=True)
class RunsComparison:
    """One level (``level`` None: all levels) of two recipes, each trained several times: every
    run's pass rate on the ``episodes`` all runs hold, and the difference of the means ``other -
    base`` with Welch's 95 % interval over the runs (fractions)."""

    level: int | None
    episodes: int
    base: tuple[float, ...]
    other: tuple[float, ...]

    @property
    def difference(self) -> float:
        return sum(self.other) / len(self.other) - sum(self.base) / len(self.base)

    @property
    def unspread(self) -> bool:
        """Every run of each side passed as many episodes as the others of its side: the runs show
        no training chance to build Welch's interval from."""
        return len(set(self.base)) == 1 and len(set(self.other)) == 1

    @property
    def interval(self) -> tuple[float, float]:
        """Welch's over the runs; where no side has any spread (:attr:`unspread`), the episodes'
        chance is all that is left to count: the two rates' Newcombe interval on one run's episodes
        (else the interval would shrink to the point, and a level passed 60 times of 110 by every run
        of one side and 61 by every run of the other would be called a difference)."""
        from aaai.train.power import welch_interval

        if self.unspread:
            passes = [round(side[0] * self.episodes) for side in (self.base, self.other)]
            return newcombe(Rate(passes[0], self.episodes), Rate(passes[1], self.episodes))
        return welch_interval(list(self.other), list(self.base))

    @property
    def verdict(self) -> str:
        return verdict(self.interval)


def compare_runs(base: list[list[dict]], other: list[list[dict]]) -> list[RunsComparison]:
    """Per level, then all levels: each scoreboard's pass rate (one a training run) on the episodes
    every scoreboard holds; 2 or more runs a side."""
    for side, boards in (("base", base), ("other", other)):
        if len(boards) < 2:
            raise ConfigError(
                f"compare: {len(boards)} training run of the {side}; allowed: 2 or more a side "
                "(the spread between runs is what the interval is made of)"
            )
    outcomes = [{_key(r): passed(r) for r in rows} for rows in base + other]
    common = sorted(set.intersection(*(set(board) for board in outcomes)))
    if not common:
        raise ConfigError("compare: the scoreboards share no episode (level, difficulty and seed)")
    lines = []
    for level, keys in by_level(common):
        rates = [sum(board[key] for key in keys) / len(keys) for board in outcomes]
        lines.append(RunsComparison(level, len(keys), tuple(rates[: len(base)]), tuple(rates[len(base) :])))
    return lines


def runs_markdown(lines: list[RunsComparison], base_names: list[str], other_names: list[str]) -> str:
    """The per-level table of :func:`compare_runs`: episodes, each run's pass rate and the mean of
    each side, the difference of the means in points with its 95 % interval and its verdict."""

    def rates(values: tuple[float, ...]) -> str:
        return " / ".join(f"{100 * value:.0f}" for value in values)

    def mean(values: tuple[float, ...]) -> str:
        return f"{100 * sum(values) / len(values):.0f}%"

    def points(value: float) -> str:  # signed whole points, never "-0"
        return "nan" if math.isnan(value) else f"{round(100 * value):+d}"

    def mark(line: RunsComparison) -> str:
        return " *" if line.unspread else ""

    base, other = f"{base_names[0]} ({len(base_names)} runs)", f"{other_names[0]} ({len(other_names)} runs)"
    out = [
        f"| level | episodes | {base}: each run | mean | {other}: each run | mean | "
        "difference of means (points, 95 % over runs) | |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for line in lines:
        level = None if line.level is None else get_level(line.level)
        label = "**all levels**" if level is None else f"{level.label} {level.name}"
        low, high = line.interval
        out.append(
            f"| {label} | {line.episodes} | {rates(line.base)} | {mean(line.base)} | {rates(line.other)} | "
            f"{mean(line.other)} | {points(line.difference)} ({points(low)} to {points(high)}){mark(line)} | "
            f"{line.verdict} |"
        )
    out += [
        "",
        f"Runs, in the order of each run's column: {', '.join(base_names)} against {', '.join(other_names)}. "
        "Each run's pass rate is one value; the interval is Welch's t over the runs, so it counts the "
        "training's chance as well as the episodes'.",
    ]
    if any(line.unspread for line in lines):
        out.append(
            "\n\\* Every run of a side passed as many episodes as the other runs of its side, so the runs show no "
            "spread to count the training's chance by: the interval is the episodes' alone (Newcombe's, on one "
            "run's episodes)."
        )
    return "\n".join(out) + "\n"


def weakest(lines: list[LevelComparison], count: int = WEAKEST) -> list[int]:
    """The ``count`` levels where the base passes least (ties by level id)."""
    levels = [line for line in lines if line.level is not None]
    return [line.level for line in sorted(levels, key=lambda line: (line.base.value, line.level))[:count]]  # type: ignore[misc]


def comparison_markdown(lines: list[LevelComparison], base_name: str, other_name: str) -> str:
    """The per-level table: episodes, each pass rate with its 95 % interval, the difference in
    points with its 95 % interval and its verdict, the episodes only ``other`` passed and only the
    base passed with McNemar's exact p on them; the base's weakest levels marked, and a last line
    counting where ``other`` is better there and overall."""
    marked = weakest(lines)
    out = [
        f"| level | episodes | {base_name} | {other_name} | difference (points, 95 %) | | gained / lost | paired p |",
        "|---|---:|---:|---:|---:|---|---:|---:|",
    ]
    for line in lines:
        if line.level is None:
            label = "**all levels**"
        else:
            level = get_level(line.level)
            label = f"{level.label} {level.name}" + (" (weakest)" if line.level in marked else "")
        low, high = line.interval
        out.append(
            f"| {label} | {line.base.episodes} | {line.base.text()} | {line.other.text()} | "
            f"{100 * line.difference:+.0f} ({100 * low:+.0f} to {100 * high:+.0f}) | {line.verdict} | "
            f"{line.gained} / {line.lost} | {line.paired_p:.2g} |"
        )
    by_level = {line.level: line for line in lines}
    better = [get_level(level).label for level in marked if by_level[level].verdict == "better"]
    overall = by_level[None]
    out += [
        "",
        f"{other_name} is better than {base_name} (the interval of the difference above 0) on {len(better)} of "
        f"{base_name}'s {len(marked)} weakest levels" + (f" ({', '.join(better)})" if better else "") + "; "
        f"over all levels: {overall.verdict}.",
    ]
    return "\n".join(out) + "\n"
