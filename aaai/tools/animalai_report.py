"""``aaai import-animalai SOURCE --out DIR --report REPORT``: the importer's coverage, measured.

Every arena of SOURCE is converted (aaai.tools.animalai) and every converted file is checked on
every seed (aaai.levels.validate through aaai.task.arena), and the counts by cause go to
REPORT/coverage.csv (one row per arena) and REPORT/coverage.md (the counts): converted or not and
why, valid on every seed or not and why (and the concrete cause behind the first problem:
aaai.tools.animalai_causes), and what the importer changed to make it fit (a start
moved, a larger scale).
"""

from __future__ import annotations

import csv
import io
import re
import time
from collections import Counter
from pathlib import Path
from typing import Callable

from aaai.config import ConfigError
from aaai.files import write_atomic
from aaai.tools.animalai_causes import OUT_OF_REACH, problem_cause
from aaai.tools.animalai_fit import cause

COLUMNS = ("source", "arena", "file", "category", "converted", "not_converted_because", "valid_seeds", "seeds",
           "valid_every_seed", "invalid_because", "cause", "changes", "unfair", "first_problem")  # fmt: skip


def category(source: str) -> str:
    """An Animal-AI competition file's category: the number its name begins with (01-...)."""
    found = re.match(r"(\d+)-", source)
    return found.group(1) if found else ""


def measure(
    source: Path, out: Path, report: Path | None, seeds: int = 10, echo: Callable[[str], object] = print, **options
) -> list[dict]:
    """Imports ``source`` into ``out``, checks every converted file on seeds 0..seeds-1 and writes
    ``report``/coverage.csv and coverage.md (when ``report`` is given); returns the rows."""
    from aaai.task.arena import check_arena, parse_arena
    from aaai.tools.animalai import UNFAIR, import_animalai

    lines: list[str] = []
    began = time.process_time()
    results = import_animalai(source, out, echo=lines.append, **options)
    rows = []
    for result in results:
        row: dict = dict.fromkeys(COLUMNS, "")
        row.update(source=result.source, arena=result.arena, file=result.name, category=category(result.source))
        row.update(changes="; ".join(result.changes), unfair="; ".join(result.unfair), seeds=seeds)
        if result.problem:
            why = cause(result.problem)
            row.update(converted="no", not_converted_because=why, cause=why, first_problem=result.problem)
            row.update(valid_seeds=0, valid_every_seed="no")
            rows.append(row)
            continue
        row["converted"] = "yes"
        if result.unfair:
            row["file"] = f"{UNFAIR}/{result.name}"
        valid, causes, first, why = 0, Counter[str](), "", ""
        for seed in range(seeds):
            spec = None
            try:
                spec, _, where = parse_arena(out / row["file"], seed)
                problems = check_arena(spec, where)
            except ConfigError as error:
                problems = list(getattr(error, "problems", None) or [str(error)])
            valid += not problems
            causes.update({cause(p) for p in problems})
            if problems and not first:  # the cause behind the first problem (aaai.tools.animalai_causes)
                first, why = problems[0], problem_cause(spec, problems[0])
        row.update(valid_seeds=valid, valid_every_seed="yes" if valid == seeds else "no")
        row.update(invalid_because="; ".join(sorted(causes)), cause=why, first_problem=first)
        rows.append(row)
    if report is not None:
        write(rows, Path(report), source, seeds, time.process_time() - began)
    summary(rows, seeds, echo)
    return rows


def counts(rows: list[dict], seeds: int) -> list[tuple[str, int, str]]:
    """(what, arenas, note) for the report's table."""
    total = len(rows)
    converted = [r for r in rows if r["converted"] == "yes"]
    valid = [r for r in converted if r["valid_every_seed"] == "yes"]
    table = [("arenas", total, ""), ("converted", len(converted), _share(len(converted), total))]
    for why, n in Counter(r["not_converted_because"] for r in rows if r["converted"] == "no").most_common():
        table.append((f"  not converted: {why}", n, ""))
    table.append((f"valid on every seed 0 to {seeds - 1}", len(valid), _share(len(valid), total) + " of all"))
    invalid = Counter(c for r in converted if r["valid_every_seed"] == "no" for c in r["invalid_because"].split("; "))
    for why, n in invalid.most_common():
        table.append((f"  not valid on some seed: {why}", n, "an arena may have several causes"))
    changes = Counter(re.sub(r" \(.*", "", c) for r in rows for c in r["changes"].split("; ") if c)
    for what, n in changes.most_common():
        table.append((f"changed to fit: {what}", n, ""))
    unfair = Counter(u for r in rows for u in r["unfair"].split("; ") if u)
    for why, n in unfair.most_common():
        table.append((f"marked unfair: {why}", n, "kept, with the reason"))
    return table


def cause_counts(rows: list[dict]) -> list[tuple[str, int, str]]:
    """(cause, arenas, by category) of the arenas not valid on every seed, by the concrete cause of
    each one's first problem (aaai.tools.animalai_causes), most first."""
    invalid = [r for r in rows if r["valid_every_seed"] != "yes"]
    found = Counter(r["cause"] for r in invalid)
    order = {name: k for k, name in enumerate(OUT_OF_REACH)}
    table = []
    for why, n in sorted(found.items(), key=lambda kv: (-kv[1], order.get(kv[0], len(order)), kv[0])):
        where = Counter(r["category"] for r in invalid if r["cause"] == why)
        table.append((why, n, ", ".join(f"{c or '-'} {k}" for c, k in sorted(where.items()))))
    return table


def _share(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f} %" if whole else ""


def summary(rows: list[dict], seeds: int, echo: Callable[[str], object]) -> None:
    for what, n, note in counts(rows, seeds):
        echo(f"{what:<60} {n:>5}  {note}")
    for why, n, _ in cause_counts(rows):
        echo(f"{'  first problem: ' + why:<60} {n:>5}")


def write(rows: list[dict], report: Path, source: Path, seeds: int, cpu: float = 0.0) -> None:
    report.mkdir(parents=True, exist_ok=True)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(report / "coverage.csv", buffer.getvalue())
    lines = [
        "# Animal-AI battery: coverage of the importer",
        "",
        f"Made by `aaai import-animalai .../{source.name} --out DIR --report {report}` (every converted",
        f"arena checked on seeds 0 to {seeds - 1}; {cpu / 60:.1f} CPU-minutes here). One row per arena in",
        "`coverage.csv`; regenerate both with the same command.",
        "",
        "| | arenas | |",
        "|---|---:|---|",
    ]
    lines += [f"| {what.strip()} | {n} | {note} |" for what, n, note in counts(rows, seeds)]
    by_category: dict[str, list[dict]] = {}
    for row in rows:
        by_category.setdefault(row["category"], []).append(row)
    lines += [
        "",
        "Not valid on every seed, by the cause of the first problem (aaai/tools/animalai_causes.py; the",
        "`cause` column of `coverage.csv`):",
        "",
        "| cause | arenas | by category |",
        "|---|---:|---|",
    ]
    lines += [f"| {why} | {n} | {where} |" for why, n, where in cause_counts(rows)]
    lines += ["", "| category | arenas | converted | valid on every seed |", "|---|---:|---:|---:|"]
    for name, group in sorted(by_category.items()):
        converted = sum(r["converted"] == "yes" for r in group)
        valid = sum(r["valid_every_seed"] == "yes" for r in group)
        lines.append(f"| {name or '-'} | {len(group)} | {converted} | {valid} |")
    write_atomic(report / "coverage.md", "\n".join(lines) + "\n")
