"""A study's store: participants, their orders, trials, rows and replays in one SQLite file.

The file is in WAL mode with ``synchronous=FULL``: every write is one transaction, durable when
it returns, so a trial finished (its row and replay) is on disk before the next trial starts and a
killed server loses none. One process writes at a time: every write transaction is taken under the
lock file ``<store>.lock`` (:func:`aaai.files.hold`), which a writer holds only for that
transaction (milliseconds), so ``aaai study participants`` adds participants beside a running
server, each waiting for the other's write to end (at most :data:`WRITE_WAIT` seconds, then
refused naming the holder's pid). One server serves a store at a time: it holds
``<store>.serving`` while it runs, and a second is refused naming the first's pid. Readers
(``aaai study export``, ``report``) need no lock. Nothing about a participant is kept but a code
(P001), a random token for their link, their order seed, their progress and what they did in the
game: no names, no IP addresses.
"""

from __future__ import annotations

import contextlib
import json
import secrets
import sqlite3
import threading
import time
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from aaai.errors import ConfigError
from aaai.files import InUse, Lock, hold
from aaai.study.order import battery_order
from aaai.study.studyfile import Study, Trial

SCHEMA = """
CREATE TABLE IF NOT EXISTS study (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS participants (
    id TEXT PRIMARY KEY,
    number INTEGER NOT NULL UNIQUE,
    token TEXT NOT NULL UNIQUE,
    order_seed INTEGER NOT NULL,
    status TEXT NOT NULL DEFAULT 'new',
    created TEXT NOT NULL,
    consented TEXT,
    finished TEXT
);
CREATE TABLE IF NOT EXISTS trials (
    participant TEXT NOT NULL REFERENCES participants(id),
    position INTEGER NOT NULL,
    kind TEXT NOT NULL,
    trial INTEGER NOT NULL,
    level INTEGER,
    difficulty INTEGER,
    seed INTEGER NOT NULL,
    arena TEXT,
    started TEXT,
    finished TEXT,
    reaction_time REAL,
    path_m REAL,
    row TEXT,
    replay TEXT,
    PRIMARY KEY (participant, position)
);
CREATE TABLE IF NOT EXISTS attempts (
    participant TEXT NOT NULL,
    position INTEGER NOT NULL,
    attempt INTEGER NOT NULL,
    started TEXT NOT NULL,
    saved TEXT NOT NULL,
    ended TEXT,
    state TEXT NOT NULL DEFAULT 'playing',
    reason TEXT,
    steps INTEGER NOT NULL DEFAULT 0,
    seconds REAL NOT NULL DEFAULT 0,
    food_eaten INTEGER NOT NULL DEFAULT 0,
    path_m REAL NOT NULL DEFAULT 0,
    PRIMARY KEY (participant, position, attempt)
);
"""
STATUSES = ("new", "consented", "started", "finished")
# An attempt at a trial: playing (its progress saved every PROGRESS_STEPS control steps), finished
# (its row is the trial's), abandoned (the tab closed past the grace period, the server stopped or
# failed: its reason) or interrupted (still playing when its server died; found at the next start).
ATTEMPT_STATES = ("playing", "finished", "abandoned", "interrupted")
UNFINISHED = ("abandoned", "interrupted")
# Metres per world unit. The simulation is in SI units: seconds, kilograms and metres, with gravity
# 9.81 units/s^2 (configs/default.yaml, physics.gravity), so a unit is a metre (the body's footprint
# is 10 across; Animal-AI's metre is 5 units here by `aaai import-animalai`'s default --scale).
METRES_PER_UNIT = 1.0
WRITE_WAIT = 10.0  # seconds a write waits for another process's write to end before it is refused
# Columns added to a table since its first version: a store written before gets them on opening.
ADDED_COLUMNS = {"trials": {"path_m": "REAL"}}


def now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


class Store:
    """One study's SQLite file. ``writer=True`` may write (each write under the one-writer lock);
    ``serving=True`` also holds the store's serving lock while it is open (ConfigError if another
    server holds it); a reader (``writer=False``) writes nothing and takes no lock. Thread-safe
    within the process."""

    def __init__(self, path: str | Path, study_name: str, writer: bool = True, serving: bool = False):
        self.path = Path(path)
        self.writer = writer
        self.lock: Lock | None = None  # the serving lock, held while a server has the store open
        self.write_lock_path = self.path.with_name(self.path.name + ".lock")
        if writer:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            if serving:
                self.lock = hold(
                    self.path.with_name(self.path.name + ".serving"),
                    lambda pid: (
                        f"study store {str(self.path)!r} is being served by process {pid or '(unknown)'} "
                        "(another `aaai study serve`); allowed: one server per store at a time: stop it first"
                    ),
                )
        elif not self.path.is_file():
            raise ConfigError(f"study store {str(self.path)!r} does not exist; run `aaai study participants` first")
        self.mutex = threading.Lock()  # the connection, one thread at a time
        self.writing = threading.Lock()  # this process's writes, one at a time
        try:
            self.db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
            self.db.row_factory = sqlite3.Row
            if writer:
                self.db.execute(f"PRAGMA busy_timeout = {int(WRITE_WAIT * 1000)}")
                with self._write_lock():
                    self.db.execute("PRAGMA journal_mode=WAL")
                self.db.execute("PRAGMA synchronous=FULL")
                with self._transaction() as db:
                    for statement in SCHEMA.split(";"):
                        if statement.strip():
                            db.execute(statement)
                    self._add_columns()
                    db.execute("INSERT OR IGNORE INTO study VALUES ('name', ?)", (study_name,))
                    if serving:  # attempts its dead predecessor left playing
                        db.execute(
                            "UPDATE attempts SET state = 'interrupted', ended = saved, "
                            "reason = 'the server stopped (killed or failed) during it' WHERE state = 'playing'"
                        )
            found = self.db.execute("SELECT value FROM study WHERE key = 'name'").fetchone()
        except sqlite3.DatabaseError as error:
            self.close()
            raise ConfigError(f"study store {str(self.path)!r}: {error}; allowed: a store `aaai study` wrote") from None
        except BaseException:
            self.close()
            raise
        if found is None or found[0] != study_name:
            self.close()
            raise ConfigError(
                f"study store {str(self.path)!r} holds study {found[0] if found else None!r}, not {study_name!r}; "
                "allowed: the store of this study (its `store:` key)"
            )

    @contextlib.contextmanager
    def _write_lock(self) -> Iterator[None]:
        """The one-writer lock, waited for (at most WRITE_WAIT seconds) while another process holds it."""
        deadline = time.monotonic() + WRITE_WAIT
        while True:
            try:
                lock = hold(
                    self.write_lock_path,
                    lambda pid: (
                        f"study store {str(self.path)!r} is being written by process {pid or '(unknown)'} and was "
                        f"for over {WRITE_WAIT:g} s; allowed: one writer at a time, each for a moment: is it stuck?"
                    ),
                )
                break
            except InUse:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.005)
        try:
            yield
        finally:
            lock.release()

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """One write transaction: this process's writing threads one at a time, under the one-writer lock;
        committed (durable) when the block ends, rolled back if it raises."""
        if not self.writer:
            raise ConfigError(f"study store {str(self.path)!r} was opened to read; allowed: reading it")
        with self.writing, self._write_lock(), self.mutex:  # reads wait only for the transaction itself
            self.db.execute("BEGIN IMMEDIATE")
            try:
                yield self.db
            except BaseException:
                self.db.execute("ROLLBACK")
                raise
            self.db.execute("COMMIT")

    def _add_columns(self) -> None:
        for table, columns in ADDED_COLUMNS.items():
            there = {row[1] for row in self.db.execute(f"PRAGMA table_info({table})")}
            for name, kind in columns.items():
                if name not in there:
                    self.db.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")

    def check_plan(self, study: Study) -> None:
        """Records the study's practice, battery and order on first use; refuses a study file whose
        trials or order changed since (the participants' orders were drawn over the old ones)."""
        plan = json.dumps(
            {
                "practice": [_plain(t) for t in study.practice],
                "battery": [_plain(t) for t in study.battery],
                "order": study.order,
            },
            sort_keys=True,
        )
        if self.writer:
            with self._transaction() as db:
                db.execute("INSERT OR IGNORE INTO study VALUES ('plan', ?)", (plan,))
        with self.mutex:
            found = self.db.execute("SELECT value FROM study WHERE key = 'plan'").fetchone()
        if found is not None and found[0] != plan:
            raise ConfigError(
                f"study file {str(study.path)!r}: its practice, battery or order changed since its participants "
                f"were added to {str(self.path)!r}; allowed: the same trials and order, or a new store (`store:`)"
            )

    def close(self) -> None:
        if getattr(self, "db", None) is not None:
            self.db.close()
        if self.lock is not None:
            self.lock.release()

    def _write(self, sql: str, values: tuple = ()) -> None:
        with self._transaction() as db:
            db.execute(sql, values)

    def _read(self, sql: str, values: tuple = ()) -> list[dict]:
        with self.mutex:
            return [dict(row) for row in self.db.execute(sql, values).fetchall()]

    def journal_mode(self) -> str:
        return str(self._read("PRAGMA journal_mode")[0]["journal_mode"])

    # --- participants ----------------------------------------------------------------------
    def add_participants(self, study: Study, count: int) -> list[dict]:
        """``count`` new participants (numbered on from those there), each with a token and an order
        of trials; one transaction."""
        added = []
        with self._transaction() as db:
            first = db.execute("SELECT COALESCE(MAX(number), 0) FROM participants").fetchone()[0] + 1
            for number in range(first, first + count):
                pid, token, seed = f"P{number:03d}", secrets.token_urlsafe(18), secrets.randbits(31)
                db.execute(
                    "INSERT INTO participants (id, number, token, order_seed, created) VALUES (?, ?, ?, ?, ?)",
                    (pid, number, token, seed, now()),
                )
                plan = [("practice", i, t) for i, t in enumerate(study.practice)]
                order = battery_order(study.order, len(study.battery), number - 1, seed)
                plan += [("battery", i, study.battery[i]) for i in order]
                for position, (kind, index, trial) in enumerate(plan, start=1):
                    db.execute(
                        "INSERT INTO trials (participant, position, kind, trial, level, difficulty, seed, arena) "
                        "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                        (pid, position, kind, index, trial.level, trial.difficulty, trial.seed, _arena(trial)),
                    )
                added.append({"id": pid, "token": token, "order_seed": seed})
        return added

    def participant(self, token: str) -> dict | None:
        """The participant whose link carries ``token`` (compared in constant time), or None."""
        for row in self._read("SELECT * FROM participants"):
            if secrets.compare_digest(row["token"].encode(), token.encode()):
                return row
        return None

    def participants(self) -> list[dict]:
        return self._read("SELECT * FROM participants ORDER BY number")

    def consent(self, pid: str) -> None:
        self._write(
            "UPDATE participants SET status = 'consented', consented = ? WHERE id = ? AND status = 'new'", (now(), pid)
        )

    def finish(self, pid: str) -> None:
        self._write("UPDATE participants SET status = 'finished', finished = ? WHERE id = ?", (now(), pid))

    # --- trials ----------------------------------------------------------------------------
    def trials(self, pid: str | None = None) -> list[dict]:
        """A participant's trials (or everyone's) by position."""
        if pid is None:
            return self._read("SELECT * FROM trials ORDER BY participant, position")
        return self._read("SELECT * FROM trials WHERE participant = ? ORDER BY position", (pid,))

    def start_trial(self, pid: str, position: int) -> None:
        with self._transaction() as db:
            db.execute("UPDATE participants SET status = 'started' WHERE id = ? AND status != 'finished'", (pid,))
            db.execute("UPDATE trials SET started = ? WHERE participant = ? AND position = ?", (now(), pid, position))

    def finish_trial(
        self,
        pid: str,
        position: int,
        row: dict,
        replay: dict,
        reaction_time: float | None,
        path_m: float | None = None,
        seconds: float | None = None,
    ) -> None:
        """The trial's row, replay, reaction time and path (metres the trunk travelled), committed
        (durable) before this returns; its attempt in play, finished (``seconds`` played)."""
        at = now()
        with self._transaction() as db:
            db.execute(
                "UPDATE trials SET finished = ?, reaction_time = ?, path_m = ?, row = ?, replay = ? "
                "WHERE participant = ? AND position = ?",
                (at, reaction_time, path_m, json.dumps(row), json.dumps(replay, separators=(",", ":")), pid, position),
            )
            db.execute(
                "UPDATE attempts SET state = 'finished', ended = ?, saved = ?, steps = ?, seconds = ?, "
                "food_eaten = ?, path_m = ? WHERE participant = ? AND position = ? AND state = 'playing'",
                (at, at, row.get("steps", 0), seconds or 0.0, row.get("food_eaten", 0), path_m or 0.0, pid, position),
            )

    # --- attempts --------------------------------------------------------------------------
    def begin_attempt(self, pid: str, position: int) -> int:
        """A new attempt at the trial (its clock has started); its number (1, 2, ...)."""
        at = now()
        with self._transaction() as db:
            number = (
                db.execute(
                    "SELECT COALESCE(MAX(attempt), 0) FROM attempts WHERE participant = ? AND position = ?",
                    (pid, position),
                ).fetchone()[0]
                + 1
            )
            db.execute(
                "INSERT INTO attempts (participant, position, attempt, started, saved) VALUES (?, ?, ?, ?, ?)",
                (pid, position, number, at, at),
            )
        return int(number)

    def save_attempt(
        self,
        pid: str,
        position: int,
        attempt: int,
        progress: dict,
        state: str = "playing",
        reason: str | None = None,
    ) -> None:
        """An attempt's progress (``steps``, ``seconds``, ``food_eaten``, ``path_m``); with a ``state``
        other than playing, its end and why."""
        if state not in ATTEMPT_STATES:
            raise ValueError(f"attempt state {state!r}; allowed: {', '.join(ATTEMPT_STATES)}")
        at = now()
        self._write(
            "UPDATE attempts SET saved = ?, ended = ?, state = ?, reason = ?, steps = ?, seconds = ?, "
            "food_eaten = ?, path_m = ? WHERE participant = ? AND position = ? AND attempt = ? AND state = 'playing'",
            (
                at,
                None if state == "playing" else at,
                state,
                reason,
                int(progress.get("steps", 0)),
                float(progress.get("seconds", 0.0)),
                int(progress.get("food_eaten", 0)),
                float(progress.get("path_m", 0.0)),
                pid,
                position,
                attempt,
            ),
        )

    def attempts(self, pid: str | None = None) -> list[dict]:
        """Every attempt (or a participant's) with its trial's kind, level, difficulty, seed and arena;
        none from a store written before attempts were kept."""
        with self.mutex:
            there = self.db.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'attempts'").fetchone()
        if there is None:
            return []
        sql = (
            "SELECT a.*, t.kind, t.level, t.difficulty, t.seed, t.arena FROM attempts a JOIN trials t "
            "ON t.participant = a.participant AND t.position = a.position"
        )
        if pid is None:
            return self._read(sql + " ORDER BY a.participant, a.position, a.attempt")
        return self._read(sql + " WHERE a.participant = ? ORDER BY a.position, a.attempt", (pid,))


def _plain(trial: Trial) -> list:
    return [trial.level, trial.difficulty, trial.seed, _arena(trial)]


def _arena(trial: Trial) -> str | None:
    return str(trial.arena) if trial.arena is not None else None


def trial_of(row: dict[str, Any]) -> Trial:
    """A stored trial's level cell or arena file and seed."""
    arena = Path(row["arena"]) if row["arena"] else None
    return Trial(row["level"], row["difficulty"], row["seed"], arena)


__all__ = ["ATTEMPT_STATES", "METRES_PER_UNIT", "STATUSES", "UNFINISHED", "Store", "trial_of"]
