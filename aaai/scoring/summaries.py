"""A scoreboard's summary: per level (or per arena and category) and overall, the episodes, mean
return, mean ratio, % passed or better and % succeeded; as rows and as a markdown table."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from aaai.files import write_atomic
from aaai.levels import all_levels, get_level


def summarise(rows: list[dict]) -> list[dict]:
    """Per level and overall: episodes, mean return, mean ratio, % passed or better, % succeeded."""
    groups: dict[str, list[dict]] = {}
    for row in rows:
        groups.setdefault(f"{get_level(int(row['level'])).label} {row['level_name']}", []).append(row)
    ordered = sorted(groups.items(), key=lambda item: int(item[1][0]["level"])) + [("overall", rows)]
    summary = []
    for name, group in ordered:
        if not group:
            continue
        summary.append(_summary_row(name, group))
    return summary


def summary_markdown(summary: list[dict]) -> str:
    lines = [
        "| level | episodes | mean return | mean ratio | passed or better | succeeded |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for s in summary:
        lines.append(
            f"| {s['level']} | {s['episodes']} | {s['mean_return']:.3f} | {s['mean_ratio']:.3f} | "
            f"{s['passed_pct']:.0f}% | {s['succeeded_pct']:.0f}% |"
        )
    return "\n".join(lines) + "\n"


def write_summary(summary: list[dict], output: Path) -> Path:
    path = output.with_name(output.stem + "_summary.md")
    write_atomic(path, summary_markdown(summary))
    return path


def summarise_arenas(rows: list[dict], categories: dict[str, str | None]) -> list[dict]:
    """Per arena (by file name), per category (the arena file's ``category``, a level name; rows of
    arenas without one are "uncategorised") and overall: the columns of :func:`summarise`."""
    by_arena: dict[str, list[dict]] = {}
    by_category: dict[str, list[dict]] = {}
    for row in rows:
        by_arena.setdefault(f"arena {row['arena']}", []).append(row)
        by_category.setdefault(categories.get(row["arena"]) or "uncategorised", []).append(row)
    order = {level.name: level.id for level in all_levels().values()}
    groups = sorted(by_arena.items()) + [
        (f"category {get_level(name).label} {name}" if name in order else f"category {name}", group)
        for name, group in sorted(by_category.items(), key=lambda item: order.get(item[0], 10**6))
    ]
    return [_summary_row(name, group) for name, group in groups + [("overall", rows)] if group]


def _summary_row(name: str, group: list[dict]) -> dict:
    ratios = np.array([float(r["ratio"]) for r in group])
    outcomes = [r["outcome"] for r in group]
    return {
        "level": name,
        "episodes": len(group),
        "mean_return": float(np.mean([float(r["return"]) for r in group])),
        "mean_ratio": float(np.nanmean(ratios)) if np.isfinite(ratios).any() else math.nan,
        "passed_pct": 100.0 * sum(o != "failed" for o in outcomes) / len(group),
        "succeeded_pct": 100.0 * outcomes.count("succeeded") / len(group),
    }
