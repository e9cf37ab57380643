"""A study's store: participants, their orders, trials, rows, replays and attempts, through
SQLAlchemy Core: one SQLite file by default, or a PostgreSQL server (``store:`` a
``postgresql+psycopg://`` URL) for a study served from several machines.

Every write is one transaction, durable when it returns, so a trial finished (its row and replay)
is stored before the next trial starts and a killed server loses none. One writer at a time:

- SQLite (WAL mode, ``synchronous=FULL``): every write transaction is taken under the lock file
  ``<store>.lock`` (:func:`aaai.files.hold`), which a writer holds only for that transaction
  (milliseconds), so ``aaai study participants`` adds participants beside a running server, each
  waiting for the other's write to end (at most :data:`WRITE_WAIT` seconds, then refused naming
  the holder's pid). One server serves a file at a time: it holds ``<store>.serving`` while it
  runs, and a second is refused naming the first's pid.
- PostgreSQL: every write transaction first takes the study's transaction-level advisory lock
  (``pg_advisory_xact_lock``), so writes from every machine follow one another; servers on several
  machines share the store.

Readers (``aaai study export``, ``report``) take no lock. Nothing about a participant is kept but
a code (P001), a random token for their link, their order seed, their progress and what they did
in the game: no names, no IP addresses.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import secrets
import threading
import time
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from aaai.errors import ConfigError
from aaai.files import InUse, Lock, hold
from aaai.study.order import battery_order
from aaai.study.studyfile import SERVER_SCHEMES, Study, Trial

STATUSES = ("new", "consented", "started", "finished")
# An attempt at a trial: playing (its progress saved every PROGRESS_STEPS control steps), finished
# # (its row is the trial's), abandoned (the tab closed past the grace period, the server stopped or
# failed: its reason) or interrupted (still playing when its server died: found when a server of
# the SQLite file starts again, or when the participant begins the trial again).
ATTEMPT_STATES = ("playing", "finished", "abandoned", "interrupted")
UNFINISHED = ("abandoned", "interrupted")
# Metres per world unit. The simulation is in SI units: seconds, kilograms and metres, with gravity
# 9.81 units/s^2 (configs/default.yaml, physics.gravity), so a unit is a metre (the body's footprint
# is 10 across; Animal-AI's metre is 5 units here by `aaai import-animalai`'s default --scale).
METRES_PER_UNIT = 1.0
WRITE_WAIT = 10.0  # seconds a write waits for another process's write to end before it is refused
# Columns added to a table since its first version: a store written before gets them on opening.
ADDED_COLUMNS = {"trials": {"path_m": "FLOAT"}}


def now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def _schema() -> Any:
    """The tables, as SQLAlchemy metadata (each dialect writes its own DDL)."""
    from sqlalchemy import Column, Float, Integer, MetaData, Table, Text

    metadata = MetaData()
    Table("study", metadata, Column("key", Text, primary_key=True), Column("value", Text, nullable=False))
    Table(
        "participants",
        metadata,
        Column("id", Text, primary_key=True),
        Column("number", Integer, nullable=False, unique=True),
        Column("token", Text, nullable=False, unique=True),
        Column("order_seed", Integer, nullable=False),
        Column("status", Text, nullable=False, server_default="new"),
        Column("created", Text, nullable=False),
        Column("consented", Text),
        Column("finished", Text),
    )
    Table(
        "trials",
        metadata,
        Column("participant", Text, primary_key=True),
        Column("position", Integer, primary_key=True, autoincrement=False),
        Column("kind", Text, nullable=False),
        Column("trial", Integer, nullable=False),
        Column("level", Integer),
        Column("difficulty", Integer),
        Column("seed", Integer, nullable=False),
        Column("arena", Text),
        Column("started", Text),
        Column("finished", Text),
        Column("reaction_time", Float),
        Column("path_m", Float),
        Column("row", Text),
        Column("replay", Text),
    )
    Table(
        "attempts",
        metadata,
        Column("participant", Text, primary_key=True),
        Column("position", Integer, primary_key=True, autoincrement=False),
        Column("attempt", Integer, primary_key=True, autoincrement=False),
        Column("started", Text, nullable=False),
        Column("saved", Text, nullable=False),
        Column("ended", Text),
        Column("state", Text, nullable=False, server_default="playing"),
        Column("reason", Text),
        Column("steps", Integer, nullable=False, server_default="0"),
        Column("seconds", Float, nullable=False, server_default="0"),
        Column("food_eaten", Integer, nullable=False, server_default="0"),
        Column("path_m", Float, nullable=False, server_default="0"),
    )
    return metadata


def is_server_url(location: str | Path) -> bool:
    return isinstance(location, str) and location.split("://", 1)[0] in SERVER_SCHEMES


class Store:
    """One study's store: ``location`` a SQLite file's path or a PostgreSQL URL. ``writer=True``
    may write (each write one transaction under the one-writer lock); ``serving=True`` (a SQLite
    file) also holds the file's serving lock while it is open (ConfigError if another server holds
    it); a reader (``writer=False``) writes nothing and takes no lock. Thread-safe."""

    def __init__(self, location: str | Path, study_name: str, writer: bool = True, serving: bool = False):
        try:
            from sqlalchemy import create_engine, event
            from sqlalchemy.engine import URL, make_url
            from sqlalchemy.exc import ArgumentError, SQLAlchemyError
        except ImportError:
            raise ConfigError("the study store needs SQLAlchemy (the play extra: pip install -e '.[play]')") from None
        self.writer = writer
        self.lock: Lock | None = None  # the serving lock of a SQLite file, held while a server has it open
        self.writing = threading.Lock()  # this process's writes, one at a time
        self.engine: Any = None
        self.server = is_server_url(location)
        if self.server:
            try:
                url = make_url(str(location))
            except ArgumentError as error:
                raise ConfigError(f"study store {location!r}: {error}; allowed: postgresql+psycopg://USER@HOST/DB")
            if url.drivername == "postgresql":
                url = url.set(drivername="postgresql+psycopg")
            self.path = Path(url.database or "")
            self.where = url.render_as_string(hide_password=True)
            self.write_lock_path = Path()
            self.advisory_key = int.from_bytes(hashlib.sha256(study_name.encode()).digest()[:8], "big") >> 1
        else:
            self.path = Path(location)
            self.where = str(self.path)
            self.write_lock_path = self.path.with_name(self.path.name + ".lock")
            url = URL.create("sqlite", database=str(self.path))
            if writer:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                if serving:
                    self.lock = hold(
                        self.path.with_name(self.path.name + ".serving"),
                        lambda pid: (
                            f"study store {self.where!r} is being served by process {pid or '(unknown)'} "
                            "(another `aaai study serve`); allowed: one server per store at a time: stop it first"
                        ),
                    )
            elif not self.path.is_file():
                raise ConfigError(f"study store {self.where!r} does not exist; run `aaai study participants` first")
        try:
            self.engine = create_engine(url, pool_pre_ping=self.server)
            if not self.server:
                self._sqlite_events(event)
            if writer:
                with self._transaction() as db:
                    _schema().create_all(db)
                    self._add_columns(db)
                    db.exec_driver_sql(
                        "INSERT INTO study (key, value) VALUES ('name', %s) ON CONFLICT DO NOTHING"
                        if self.server
                        else "INSERT INTO study (key, value) VALUES ('name', ?) ON CONFLICT DO NOTHING",
                        (study_name,),
                    )
                    if serving and not self.server:  # attempts its dead predecessor left playing
                        db.exec_driver_sql(
                            "UPDATE attempts SET state = 'interrupted', ended = saved, "
                            "reason = 'the server stopped (killed or failed) during it' WHERE state = 'playing'"
                        )
            found = self._read("SELECT value FROM study WHERE key = 'name'")
        except InUse:
            self.close()
            raise
        except SQLAlchemyError as error:
            self.close()
            cause = str(getattr(error, "orig", None) or error).strip().splitlines()[0]
            raise ConfigError(
                f"study store {self.where!r}: {cause}; allowed: a store `aaai study` wrote (a SQLite file, "
                "or a PostgreSQL database it can reach)"
            ) from None
        except BaseException:
            self.close()
            raise
        name = found[0]["value"] if found else None
        if name != study_name:
            self.close()
            raise ConfigError(
                f"study store {self.where!r} holds study {name!r}, not {study_name!r}; "
                "allowed: the store of this study (its `store:` key)"
            )

    def _sqlite_events(self, event: Any) -> None:
        """SQLite's own transaction handling off: a write begins IMMEDIATE (the write lock at once), a
        read a plain BEGIN; WAL and full sync on every connection a writer opens."""
        writer = self.writer

        @event.listens_for(self.engine, "connect")
        def _connect(connection: Any, _record: Any) -> None:
            connection.isolation_level = None
            cursor = connection.cursor()
            cursor.execute(f"PRAGMA busy_timeout = {int(WRITE_WAIT * 1000)}")
            if writer:
                cursor.execute("PRAGMA journal_mode=WAL")
                cursor.execute("PRAGMA synchronous=FULL")
            cursor.close()

        @event.listens_for(self.engine, "begin")
        def _begin(connection: Any) -> None:
            connection.exec_driver_sql(
                "BEGIN IMMEDIATE" if connection.get_execution_options().get("write") else "BEGIN"
            )

    @contextlib.contextmanager
    def _write_lock(self) -> Iterator[None]:
        """A SQLite file's one-writer lock, waited for (at most WRITE_WAIT seconds) while another
        process holds it."""
        deadline = time.monotonic() + WRITE_WAIT
        while True:
            try:
                lock = hold(
                    self.write_lock_path,
                    lambda pid: (
                        f"study store {self.where!r} is being written by process {pid or '(unknown)'} and was "
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
    def _transaction(self) -> Iterator[Any]:
        """One write transaction (a SQLAlchemy connection): this process's writes one at a time,
        under the one-writer lock; committed (durable) when the block ends, rolled back if it raises."""
        if not self.writer:
            raise ConfigError(f"study store {self.where!r} was opened to read; allowed: reading it")
        with self.writing, contextlib.ExitStack() as stack:
            if not self.server:
                stack.enter_context(self._write_lock())
            connection = stack.enter_context(self.engine.connect().execution_options(write=True))
            with connection.begin():
                if self.server:
                    connection.exec_driver_sql("SELECT pg_advisory_xact_lock(%s)", (self.advisory_key,))
                yield connection

    def _add_columns(self, db: Any) -> None:
        from sqlalchemy import inspect

        inspector = inspect(db)
        for table, columns in ADDED_COLUMNS.items():
            there = {column["name"] for column in inspector.get_columns(table)}
            for name, kind in columns.items():
                if name not in there:
                    db.exec_driver_sql(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")

    def _sql(self, sql: str) -> Any:
        from sqlalchemy import text

        return text(sql)

    def _write(self, sql: str, **values: Any) -> None:
        with self._transaction() as db:
            db.execute(self._sql(sql), values)

    def _read(self, sql: str, **values: Any) -> list[dict]:
        with self.engine.connect() as connection:
            return [dict(row) for row in connection.execute(self._sql(sql), values).mappings().all()]

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
            self._write("INSERT INTO study (key, value) VALUES ('plan', :plan) ON CONFLICT DO NOTHING", plan=plan)
        found = self._read("SELECT value FROM study WHERE key = 'plan'")
        if found and found[0]["value"] != plan:
            raise ConfigError(
                f"study file {str(study.path)!r}: its practice, battery or order changed since its participants "
                f"were added to {self.where!r}; allowed: the same trials and order, or a new store (`store:`)"
            )

    def close(self) -> None:
        if self.engine is not None:
            self.engine.dispose()
            self.engine = None
        if self.lock is not None:
            self.lock.release()
            self.lock = None

    def journal_mode(self) -> str:
        """A SQLite file's journal mode (wal); a server's "server"."""
        if self.server:
            return "server"
        return str(self._read("PRAGMA journal_mode")[0]["journal_mode"])

    # --- participants ----------------------------------------------------------------------
    def add_participants(self, study: Study, count: int) -> list[dict]:
        """``count`` new participants (numbered on from those there), each with a token and an order
        of trials; one transaction."""
        added = []
        with self._transaction() as db:
            first = db.execute(self._sql("SELECT COALESCE(MAX(number), 0) FROM participants")).scalar_one() + 1
            for number in range(first, first + count):
                pid, token, seed = f"P{number:03d}", secrets.token_urlsafe(18), secrets.randbits(31)
                db.execute(
                    self._sql(
                        "INSERT INTO participants (id, number, token, order_seed, status, created) "
                        "VALUES (:pid, :number, :token, :seed, 'new', :at)"
                    ),
                    {"pid": pid, "number": number, "token": token, "seed": seed, "at": now()},
                )
                plan = [("practice", i, t) for i, t in enumerate(study.practice)]
                order = battery_order(study.order, len(study.battery), number - 1, seed)
                plan += [("battery", i, study.battery[i]) for i in order]
                db.execute(
                    self._sql(
                        'INSERT INTO trials (participant, "position", kind, trial, level, difficulty, seed, arena) '
                        "VALUES (:pid, :position, :kind, :trial, :level, :difficulty, :seed, :arena)"
                    ),
                    [
                        {
                            "pid": pid,
                            "position": position,
                            "kind": kind,
                            "trial": index,
                            "level": trial.level,
                            "difficulty": trial.difficulty,
                            "seed": trial.seed,
                            "arena": _arena(trial),
                        }
                        for position, (kind, index, trial) in enumerate(plan, start=1)
                    ],
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
            "UPDATE participants SET status = 'consented', consented = :at WHERE id = :pid AND status = 'new'",
            at=now(),
            pid=pid,
        )

    def finish(self, pid: str) -> None:
        self._write("UPDATE participants SET status = 'finished', finished = :at WHERE id = :pid", at=now(), pid=pid)

    # --- trials ----------------------------------------------------------------------------
    def trials(self, pid: str | None = None) -> list[dict]:
        """A participant's trials (or everyone's) by position."""
        if pid is None:
            return self._read('SELECT * FROM trials ORDER BY participant, "position"')
        return self._read('SELECT * FROM trials WHERE participant = :pid ORDER BY "position"', pid=pid)

    def start_trial(self, pid: str, position: int) -> None:
        with self._transaction() as db:
            db.execute(
                self._sql("UPDATE participants SET status = 'started' WHERE id = :pid AND status != 'finished'"),
                {"pid": pid},
            )
            db.execute(
                self._sql('UPDATE trials SET started = :at WHERE participant = :pid AND "position" = :position'),
                {"at": now(), "pid": pid, "position": position},
            )

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
                self._sql(
                    'UPDATE trials SET finished = :at, reaction_time = :reaction, path_m = :path, "row" = :row, '
                    'replay = :replay WHERE participant = :pid AND "position" = :position'
                ),
                {
                    "at": at,
                    "reaction": reaction_time,
                    "path": path_m,
                    "row": json.dumps(row),
                    "replay": json.dumps(replay, separators=(",", ":")),
                    "pid": pid,
                    "position": position,
                },
            )
            db.execute(
                self._sql(
                    "UPDATE attempts SET state = 'finished', ended = :at, saved = :at, steps = :steps, "
                    "seconds = :seconds, food_eaten = :food, path_m = :path "
                    "WHERE participant = :pid AND \"position\" = :position AND state = 'playing'"
                ),
                {
                    "at": at,
                    "steps": int(row.get("steps", 0)),
                    "seconds": float(seconds or 0.0),
                    "food": int(row.get("food_eaten", 0)),
                    "path": float(path_m or 0.0),
                    "pid": pid,
                    "position": position,
                },
            )

    # --- attempts --------------------------------------------------------------------------
    def begin_attempt(self, pid: str, position: int) -> int:
        """A new attempt at the trial (its clock has started); its number (1, 2, ...). An earlier
        attempt at it still playing (its server died) is interrupted."""
        at = now()
        where = {"pid": pid, "position": position}
        with self._transaction() as db:
            db.execute(
                self._sql(
                    "UPDATE attempts SET state = 'interrupted', ended = saved, "
                    "reason = 'the server stopped (killed or failed) during it' "
                    "WHERE participant = :pid AND \"position\" = :position AND state = 'playing'"
                ),
                where,
            )
            number = (
                db.execute(
                    self._sql(
                        "SELECT COALESCE(MAX(attempt), 0) FROM attempts "
                        'WHERE participant = :pid AND "position" = :position'
                    ),
                    where,
                ).scalar_one()
                + 1
            )
            db.execute(
                self._sql(
                    'INSERT INTO attempts (participant, "position", attempt, started, saved, state, steps, seconds, '
                    "food_eaten, path_m) VALUES (:pid, :position, :number, :at, :at, 'playing', 0, 0, 0, 0)"
                ),
                {**where, "number": number, "at": at},
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
            "UPDATE attempts SET saved = :at, ended = :ended, state = :state, reason = :reason, steps = :steps, "
            "seconds = :seconds, food_eaten = :food, path_m = :path WHERE participant = :pid "
            "AND \"position\" = :position AND attempt = :attempt AND state = 'playing'",
            at=at,
            ended=None if state == "playing" else at,
            state=state,
            reason=reason,
            steps=int(progress.get("steps", 0)),
            seconds=float(progress.get("seconds", 0.0)),
            food=int(progress.get("food_eaten", 0)),
            path=float(progress.get("path_m", 0.0)),
            pid=pid,
            position=position,
            attempt=attempt,
        )

    def attempts(self, pid: str | None = None) -> list[dict]:
        """Every attempt (or a participant's) with its trial's kind, level, difficulty, seed and arena;
        none from a store written before attempts were kept."""
        from sqlalchemy import inspect

        with self.engine.connect() as connection:
            if not inspect(connection).has_table("attempts"):
                return []
        sql = (
            "SELECT a.*, t.kind, t.level, t.difficulty, t.seed, t.arena FROM attempts a JOIN trials t "
            'ON t.participant = a.participant AND t."position" = a."position"'
        )
        if pid is None:
            return self._read(sql + ' ORDER BY a.participant, a."position", a.attempt')
        return self._read(sql + ' WHERE a.participant = :pid ORDER BY a."position", a.attempt', pid=pid)


def _plain(trial: Trial) -> list:
    return [trial.level, trial.difficulty, trial.seed, _arena(trial)]


def _arena(trial: Trial) -> str | None:
    return str(trial.arena) if trial.arena is not None else None


def trial_of(row: dict[str, Any]) -> Trial:
    """A stored trial's level cell or arena file and seed."""
    arena = Path(row["arena"]) if row["arena"] else None
    return Trial(row["level"], row["difficulty"], row["seed"], arena)


__all__ = ["ATTEMPT_STATES", "METRES_PER_UNIT", "STATUSES", "UNFINISHED", "Store", "is_server_url", "trial_of"]
