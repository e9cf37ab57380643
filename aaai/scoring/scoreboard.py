"""The scoreboard file: a CSV, one row per episode, each row durable before the next episode;
read back (a torn last line cut off, every row checked) to resume, and locked so that one eval at a
time adds to it."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Callable

from aaai.config import ConfigError
from aaai.files import Lock, hold, write_atomic
from aaai.levels import all_levels
from aaai.scoring.provenance import read_record, record_path

# "arena": the arena file's name (aaai.task.arena), empty for a generated level. A scoreboard written
# before that column existed (LEGACY_COLUMNS) is still read (its rows get arena "") and added to
# in its own columns.
LEGACY_COLUMNS = [
    "level",
    "level_name",
    "difficulty",
    "seed",
    "return",
    "max_reward",
    "ratio",
    "outcome",
    "steps",
    "max_steps",
    "food_eaten",
    "wall_hits",
    "fell",
    "wall_seconds",
]
COLUMNS = LEGACY_COLUMNS[:-1] + ["arena", "wall_seconds"]  # the timing stays last


class Scoreboard:
    """Appends rows to a scoreboard CSV, each durable (flushed and fsynced) before the next episode.

    Nothing is written before the first row: the record (``*_scored_with.json``) and, for a new
    file, the header appear with it, so an eval that fails before its first episode ends leaves no
    file behind. An OS error while writing (a full disk, a permission taken away, a folder where
    the file should be) is a ConfigError naming the file; the rows written before it stay, and the
    same command run again resumes after them.
    """

    def __init__(
        self,
        output: Path,
        record: dict,
        columns: list[str],
        rows: list[dict],
        on_episode: Callable[[dict], None] | None = None,
    ):
        self.output, self.record, self.columns, self.rows, self.on_episode = (
            Path(output),
            record,
            columns,
            rows,
            on_episode,
        )
        self.handle: io.TextIOWrapper[io.BufferedWriter] | None = None  # open from the first row on

    def _opened(self) -> io.TextIOWrapper[io.BufferedWriter]:
        """The file open for appending (opened, with the record beside it, at the first row)."""
        if self.handle is None:
            new = not self.output.exists() or self.output.stat().st_size == 0
            if new or not record_path(self.output).exists() or read_record(self.output) != self.record:  # (grown)
                write_atomic(record_path(self.output), json.dumps(self.record, indent=1, sort_keys=True) + "\n")
            self.handle = io.TextIOWrapper(open(self.output, "ab"), newline="")  # its buffer dropped on a failed write
            if new:
                csv.writer(self.handle).writerow(self.columns)
        return self.handle

    def append(self, row: dict) -> None:
        """Writes one episode's row and makes it durable before the next episode starts. A row
        that cannot be written whole is cut off again, so that the file ends with the last whole row."""
        durable = None
        try:
            handle = self._opened()
            durable = os.fstat(handle.fileno()).st_size
            csv.DictWriter(handle, fieldnames=self.columns, extrasaction="ignore").writerow(row)
            handle.flush()
            os.fsync(handle.fileno())
        except OSError as error:
            self._abandon(durable)
            raise ConfigError(write_error(self.output, error, len(self.rows))) from None
        self.rows.append({k: str(v) for k, v in row.items()})
        if self.on_episode:
            self.on_episode(row)

    def _abandon(self, durable: int | None) -> None:
        """After a failed write: drops what is still buffered (it must not reach the file later,
        mid-line) and cuts the file back to its whole rows."""
        if self.handle is None:
            return
        descriptor = self.handle.fileno()
        try:
            if durable is not None:
                os.ftruncate(descriptor, durable)
        except OSError:
            pass  # a torn last line is cut when the scoreboard is next read
        try:
            self.handle.buffer.raw.close()  # closed under the buffers: what they hold is discarded, not written
            self.handle.close()  # (a no-op once the file below is closed)
        except (OSError, ValueError):
            pass
        self.handle = None

    def close(self) -> None:
        if self.handle is not None:
            try:
                self.handle.close()
            except (OSError, ValueError):
                pass  # what could not be flushed was reported by append
            self.handle = None

    def __enter__(self) -> "Scoreboard":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_error(path: Path, error: OSError, kept: int) -> str:
    """The message for an OS error on a file an eval writes: the file, the cause, what stays."""
    where = getattr(error, "filename2", None) or getattr(error, "filename", None) or path  # a rename: its target
    cause = error.strerror or str(error) or type(error).__name__
    return (
        f"--out: cannot write {str(where)!r}: {cause}. The {kept} row(s) of {str(path)!r} written before "
        "stay; free the space or fix the permission, then run the same command again to resume"
    )


def scored_episodes(path: Path) -> list[dict]:
    """Rows already in a scoreboard; a torn last line (an interrupted write) is cut off."""
    if not path.exists():
        return []
    try:
        text = path.read_text()
    except UnicodeDecodeError as error:
        raise ConfigError(
            f"{str(path)!r} is not a scoreboard: byte {error.start} is not UTF-8 text; allowed: a CSV an eval wrote"
        ) from None
    if text and not text.strip():  # blank lines only: no header and no rows, so it starts afresh
        with open(path, "r+") as handle:
            handle.truncate(0)
        return []
    if text and not text.endswith("\n"):
        with open(path, "r+") as handle:
            handle.truncate(text.rfind("\n") + 1)
        text = text[: text.rfind("\n") + 1]
    try:
        rows = list(csv.DictReader(text.splitlines()))
    except csv.Error as error:
        raise ConfigError(f"{str(path)!r} is not a scoreboard ({error}); allowed: a CSV an eval wrote") from None
    whole = [row for row in rows if None not in row and None not in row.values()]
    if len(whole) < len(rows):  # a line torn mid-file (a write cut short, then appended to): played again
        lines = text.splitlines(keepends=True)
        write_atomic(path, lines[0] + "".join(line for line, row in zip(lines[1:], rows) if row in whole))
        rows = whole
    if rows and list(rows[0].keys()) == LEGACY_COLUMNS:
        rows = [{**row, "arena": ""} for row in rows]
    elif rows and list(rows[0].keys()) != COLUMNS:
        raise ConfigError(f"{str(path)!r} is not a scoreboard of this version (columns {list(rows[0].keys())})")
    for number, row in enumerate(rows, 2):
        _check_row(path, number, row)
    return rows


def _check_row(path: Path, number: int, row: dict) -> None:
    """A row of a scoreboard being continued holds what an eval writes: the level of a level this
    version has, whole numbers for difficulty, seed and steps, a number for the return."""
    for key, kind in (
        ("level", int),
        ("difficulty", int),
        ("seed", int),
        ("steps", int),
        ("return", float),
        ("ratio", float),
    ):
        try:
            kind(row[key])
        except (TypeError, ValueError):
            raise ConfigError(
                f"{str(path)!r} row {number}: {key} {row[key]!r} is not a number; allowed: rows an eval wrote "
                "(delete the row, and the eval plays its episode again)"
            ) from None
    if int(row["level"]) not in set(all_levels()):
        raise ConfigError(
            f"{str(path)!r} row {number}: level {row['level']!r} does not exist; allowed: rows an eval wrote "
            "(delete the row, and the eval plays its episode again)"
        )


def columns_of(path: Path) -> list[str]:
    """The columns to add rows to a scoreboard in: its own header's if it is an older scoreboard
    (without "arena"), else COLUMNS."""
    if path.exists():
        with open(path, newline="") as handle:
            header = next(csv.reader(handle), None)
        if header == LEGACY_COLUMNS:
            return LEGACY_COLUMNS
    return COLUMNS


def scoreboard_lock(output: Path) -> Lock:
    """The lock on a scoreboard (``.NAME.lock`` beside it, holding the pid), held while an eval
    reads and adds to it: another eval of the same file refuses at once, naming the holder."""
    return hold(
        output.with_name(f".{output.name}.lock"),
        lambda pid: (
            f"--out: scoreboard {str(output)!r} is being written by "
            + (f"process {pid}" if pid else "another process")
            + "; allowed: one eval at a time per scoreboard (wait for it to end, or choose another --out)"
        ),
    )
