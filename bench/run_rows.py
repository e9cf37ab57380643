"""What the run-timing scripts in bench/ share: the load average, their resumable CSV (written
atomically), and a run's reserved-seed score."""

from __future__ import annotations

import csv
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
AAAI = str(Path(sys.executable).parent / "aaai")


def load() -> float:
    """The 1-minute load average."""
    return round(os.getloadavg()[0], 2)


def read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open() as handle:
        return list(csv.DictReader(handle))


def write_rows(path: Path, rows: list[dict], fields: list[str]) -> None:
    """All rows, written to a temporary file and moved into place: an interrupted write loses nothing."""
    temporary = path.with_suffix(".tmp")
    with temporary.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    temporary.replace(path)


def score(run: Path) -> tuple[int, int, float]:
    """(passed or better, episodes, mean return) of ``aaai eval --seeds reserved --policy run``,
    run once and then read from the run's scoreboard."""
    out = run / "scoreboard_reserved.csv"
    if not out.exists():
        command = [AAAI, "eval", "--seeds", "reserved", "--policy", str(run)]
        subprocess.run(command, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    with out.open() as handle:
        rows = list(csv.DictReader(handle))
    passed = sum(row["outcome"] != "failed" for row in rows)
    return passed, len(rows), statistics.mean(float(row["return"]) for row in rows)
