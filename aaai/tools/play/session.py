"""One player's session of ``aaai play``: a battery of episodes played from the keyboard in real time.

A session owns an environment (in gait mode, one control step per ``env.step``) and a thread that
scores the battery with ``aaai.scoring.evaluation.evaluate`` (or ``evaluate_arenas``), exactly as ``aaai
eval`` does: the same rows, the same resume at the next unplayed episode, the same
``*_scored_with.json``; only the policy is the player's (``HumanPolicy``), recorded as
``human:NAME``. The policy paces the simulation by a clock of its own: a control step is taken
when the wall clock has reached it, never earlier (the simulation never runs ahead of real time);
after a stall the clock slips rather than racing to catch up. The clock stops on a start or pause
screen, and the browser only watches: its frame rate changes nothing.

Nothing here knows about the web: the server (aaai.tools.play.server) passes key, focus and frame
acknowledgements in, and sends out what ``status()`` and ``frame()`` give.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import re
import secrets
import threading
import time
import traceback
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from aaai.config import Config, ConfigError
from aaai.files import append_row
from aaai.levels import get_level
from aaai.scoring.evaluation import Cell, evaluate, evaluate_arenas, policy_record, scored_episodes
from aaai.scoring.policies import external
from aaai.tools.viewer import camera_image, draw_snapshot

# event.key values (letters lower-cased) -> the control they hold down.
CONTROL_KEYS = {
    "ArrowUp": "forward",
    "w": "forward",
    "ArrowDown": "backward",
    "s": "backward",
    "ArrowLeft": "left",
    "a": "left",
    "ArrowRight": "right",
    "d": "right",
    "c": "crouch",
    "Shift": "crouch",
}
GO_KEYS = (" ", "Enter")  # start an episode, go on after a pause (any control key does too)
KEYS = tuple(CONTROL_KEYS) + GO_KEYS
PLAYER_NAME = re.compile(r"[A-Za-z0-9_-]{1,40}")  # ASCII letters and digits, '-' and '_'
MAX_PLAYER_CHARS = 40
MAX_LAG = 0.1  # seconds the simulation may fall behind the clock before the clock slips
PHASES = ("loading", "ready", "running", "paused", "finished", "abandoned", "error")

# What the player is asked to do, one line per shipped level (by name); other levels and arena
# files say their title or description.
TASKS = {
    "food_contact": "Walk to the green ball and touch it with your head.",
    "food_retrieval": "Eat the food: yellow balls add to your score, a green one ends the episode. "
    "Get as much as you can.",
    "y_maze": "Choose one arm of the Y-maze: only one green ball can be eaten, and the bigger is worth more.",
    "delayed_gratification": "A small green ball lies ahead; a yellow one sinks from a pillar. "
    "Eat the yellow first, then the green.",
    "obstacles": "The green ball is behind a see-through wall: find your way round the obstacles.",
    "avoidance": "Reach the green ball without falling into a hole in the floor (falling ends the episode).",
    "spatial_reasoning": "Find your way through the maze to the green ball.",
    "robustness": "Everything is in unfamiliar colours: find the food all the same.",
    "internal_models": "The lights go out every few seconds: remember where the food is.",
    "object_permanence": "Watch where the green ball goes behind the wall, then go and get it. Mind the pit.",
    "numerosity": "Four sectors hold yellow food: go into the one with the most. Its door closes behind you.",
    "causal_reasoning": "Push the plank over so that it falls across the trench, then cross to the green ball.",
    "body_awareness": "Cross the rough ground to the green ball.",
}
ABANDONED_COLUMNS = [
    "player",
    "level",
    "level_name",
    "difficulty",
    "seed",
    "arena",
    "steps",
    "max_steps",
    "food_eaten",
    "reason",
    "utc",
]


class Abandoned(Exception):
    """The player left (the tab closed, the server stopped) during the battery."""


class InputError(ValueError):
    """A message from a page that is not allowed (an unknown key, a bad player name)."""


def check_player(name: object) -> str:
    """A player's name, checked: the one way a name becomes part of a file name (the scoreboard's
    ``{player}``, the replays' prefix). 1 to 40 ASCII letters, digits, '-' and '_', so that no name
    can climb out of a folder (``..``), name another one (``/``) or be empty; InputError otherwise."""
    if not isinstance(name, str) or not PLAYER_NAME.fullmatch(name):
        shown = repr(name)
        if isinstance(name, str) and len(name) > MAX_PLAYER_CHARS:
            shown = f"{name[:MAX_PLAYER_CHARS]!r}... ({len(name)} characters)"
        elif not isinstance(name, str):
            shown = f"{shown[:MAX_PLAYER_CHARS]} (a {type(name).__name__})"
        raise InputError(
            f"player: got {shown}; allowed: 1 to {MAX_PLAYER_CHARS} letters (A-Z, a-z), digits, '-' or '_'"
        )
    return name


def control_of(key: object) -> str | None:
    """The control a key holds (None for a start key); InputError for a key that does nothing."""
    if not isinstance(key, str):
        raise InputError(f"key: got {str(key)[:40]} (a {type(key).__name__}); allowed: {', '.join(map(repr, KEYS))}")
    if len(key) == 1:
        key = key.lower()
    if key in CONTROL_KEYS:
        return CONTROL_KEYS[key]
    if key in GO_KEYS:
        return None
    raise InputError(f"key: got {key!r}; allowed: {', '.join(repr(k) for k in KEYS)}")


def command_of(controls: set[str]) -> tuple[float, float, float]:
    """(forward, turn, crouch) of the gait for the controls held: opposite keys cancel."""
    forward = float(("forward" in controls) - ("backward" in controls))
    turn = float(("left" in controls) - ("right" in controls))
    return forward, turn, float("crouch" in controls)


def task_of(level: int, arena: Path | None = None) -> str:
    if arena is not None:
        from aaai.task.arena import arena_meta

        return arena_meta(arena)["description"] or f"Arena {arena.stem}: find the food."
    lvl = get_level(level)
    return TASKS.get(lvl.name, f"{lvl.title}: find the food.")


@dataclass
class PlaySettings:
    """What a server's sessions play and where their results go."""

    config: Config  # the resolved config (gait mode, one control step per action, the camera on)
    cells: list[Cell] = field(default_factory=list)  # the battery of generated levels ...
    arenas: list[Path] = field(default_factory=list)  # ... or of arena files, on arena_seeds
    arena_seeds: list[int] = field(default_factory=list)
    seeds_label: str = "list"  # what the scored_with record says of the seeds (reserved, train, list)
    seed_key: str | None = None
    output: str = "human_{player}.csv"  # the scoreboard; {player} is the player's name
    player: str | None = None  # a fixed player (the page asks for a name when None)
    replays: Path | None = None  # a replay per scored episode goes here
    max_fps: float = 30.0  # frames sent to a page per second, at most
    map_size: int = 480
    between_seconds: float = 1.0  # after an episode, keys are ignored this long (a key held on is not a start)
    grace_seconds: float = 20.0  # a page that drops its socket may come back this long before its episode is abandoned
    max_sessions: int | None = None  # sessions holding an environment at once (None: the server's default)
    idle_seconds: float = 600.0  # a session with no key pressed (and no page joining it) this long is abandoned

    def output_for(self, player: str) -> Path:
        return Path(self.output.replace("{player}", check_player(player)))

    def record(self, player: str) -> dict:
        record = policy_record(external(f"human:{player}"), self.seeds_label, self.seed_key)
        if self.arenas:
            record["arenas"] = ", ".join(str(a) for a in self.arenas)
        return record

    def episodes(self) -> list[tuple]:
        """The battery in order: (level, difficulty, seed, arena path or None)."""
        if self.arenas:
            return [(None, None, seed, arena) for arena in self.arenas for seed in self.arena_seeds]
        return [(cell.level, cell.difficulty, seed, None) for cell in self.cells for seed in cell.seeds]


class HumanPolicy:
    """The player as a policy: the gait command of the keys held, one action per control step,
    each when the session's clock says so."""

    def __init__(self, session: "Session", env):
        self.session, self.env = session, env.unwrapped

    def reset(self, seed: int) -> None:
        self.session._episode_reset(self.env)

    def __call__(self, observation):
        return self.session._next_action(self.env, observation)

    def end_episode(self, result) -> None:
        self.session._episode_end(self.env, result)


class Session:
    """One player in one tab. Thread-safe: the server calls ``key``, ``focus``, ``ack``,
    ``attach``/``detach`` and ``abandon`` from its event loop; the battery runs on its own thread."""

    def __init__(
        self,
        settings: PlaySettings,
        player: str,
        notify: Callable[[], None] = lambda: None,
        on_end: Callable[["Session"], None] | None = None,
    ):
        self.settings, self.player = settings, check_player(player)
        self.on_end = on_end  # called on the session's thread when the battery is over (its environment closed)
        self.done = threading.Event()  # set then (the server no longer counts it)
        self.token = secrets.token_urlsafe(18)
        self.output = settings.output_for(player)
        self.notify = notify
        self.cond = threading.Condition()
        self.phase, self.message = "loading", ""
        self.keys: set[str] = set()  # keys held down
        self.focused, self.attached = True, True
        self.abandon_reason: str | None = None
        self.started = False  # the current episode's clock has started
        self.deadline = 0.0  # monotonic time of the next control step
        self.ready_at = 0.0  # start keys count from this monotonic time
        self.env = None
        self.episode: dict = {}  # the current episode: level, names, task, index, total
        self.live: dict = {}  # steps, time left, food, pose, command
        self.last: dict | None = None  # the last scored row
        self.rows: list[dict] = []
        self.version = 0  # bumped on every change a page should see
        self.frame_data: list[bytes] | None = None  # the last frame's camera PNG and map JPEG
        self.frame_no, self.acked, self.next_frame_at = 0, 0, 0.0
        self.delivered: list[float] = []  # monotonic times of acknowledged frames (the last second's)
        self.force_frame = False
        self.last_input = time.monotonic()  # the last key pressed or page attached (see PlaySettings.idle_seconds)
        self.thread = threading.Thread(target=self._run, name=f"aaai-play-{player}", daemon=True)

    # --- from the page ---------------------------------------------------------------
    def start(self) -> None:
        self.thread.start()

    def key(self, key: object, down: bool) -> None:
        control = control_of(key)
        assert isinstance(key, str)  # control_of refuses any other
        name = key.lower() if len(key) == 1 else key
        with self.cond:
            self.last_input = time.monotonic()
            if down:
                now = time.monotonic()
                if self.phase in ("ready", "paused") and self.focused and self.attached and now >= self.ready_at:
                    self._set_phase("running")
                    self.started, self.deadline = True, now
                if control is not None and self.phase == "running":
                    self.keys.add(name)
            else:
                self.keys.discard(name)
            self._changed()

    def focus(self, focused: bool) -> None:
        with self.cond:
            self.focused = bool(focused)
            if not self.focused:
                self._pause("the page lost focus")
            self._changed()

    def ack(self, frame_no: int) -> None:
        with self.cond:
            if isinstance(frame_no, int) and self.acked < frame_no <= self.frame_no:
                self.acked = frame_no
                now = time.monotonic()
                self.delivered = [t for t in self.delivered if now - t < 1.0] + [now]
            self.cond.notify_all()

    def attach(self, notify: Callable[[], None]) -> None:
        with self.cond:
            self.attached, self.notify, self.focused = True, notify, True
            self.last_input = time.monotonic()
            self.acked = self.frame_no - 1 if self.frame_data is not None else 0  # the new page has seen nothing:
            self.force_frame = True  # the newest frame goes to it now (even while paused), and a new one follows
            self._changed()

    def detach(self) -> None:
        with self.cond:
            self.attached = False
            self._pause("the connection dropped")
            self._changed()

    def abandon(self, reason: str) -> None:
        with self.cond:
            if self.phase not in ("finished", "error", "abandoned"):
                self.abandon_reason = reason
            self._changed()

    # --- to the page -----------------------------------------------------------------
    def status(self) -> dict:
        with self.cond:
            now = time.monotonic()
            return {
                "player": self.player,
                "phase": self.phase,
                "message": self.message,
                "episode": dict(self.episode),
                **self.live,
                "last": self.last,
                "scored": len(self.rows),
                "output": str(self.output),
                "fps": len([t for t in self.delivered if now - t < 1.0]),
                "frame": self.frame_no,
                "version": self.version,
                "accepts_start": self.phase in ("ready", "paused") and now >= self.ready_at,
            }

    def frame(self) -> tuple[int, list[bytes]] | None:
        """The newest frame not yet acknowledged by the page: its number and images (camera PNG,
        map JPEG); None when the page has it already."""
        with self.cond:
            if self.frame_data is None or self.acked >= self.frame_no:
                return None
            return self.frame_no, self.frame_data

    # --- the battery's thread ---------------------------------------------------------
    def _run(self) -> None:
        try:
            self._play()
        finally:
            with self.cond:
                self.env = None  # closed by now (evaluate closes it): nothing keeps its memory
            self.done.set()
            if self.on_end is not None:
                self.on_end(self)

    def _play(self) -> None:
        settings = self.settings
        try:
            done = {self._key_of(row) for row in scored_episodes(self.output)}
            episodes = settings.episodes()
            self.remaining = [e for e in episodes if self._key_of_episode(e) not in done]
            self.total, self.played = len(episodes), len(episodes) - len(self.remaining)
            if not self.remaining:
                self._finish(f"every episode of this battery is in {self.output} already")
                return
            make_policy, on_episode = self._policy_makers()
            record = settings.record(self.player)
            player = external(f"human:{self.player}")
            common = {"on_episode": on_episode, "record": record, "make_policy": make_policy}
            if settings.arenas:
                evaluate_arenas(player, settings.arenas, settings.arena_seeds, self.output, settings.config, **common)
            else:
                evaluate(player, settings.cells, self.output, settings.config, **common)
            self._finish(
                f"the battery is done ({self.total} episode{'s' * (self.total != 1)}); the scores are in {self.output}"
            )
        except Abandoned:
            self._write_abandoned()
        except ConfigError as error:
            self._fail(str(error))
        except Exception as error:  # noqa: BLE001 - the page is told, the server goes on serving others
            traceback.print_exc()
            self._fail(f"{type(error).__name__}: {error}")

    def _policy_makers(self):
        def human(env):
            return HumanPolicy(self, env)

        if self.settings.replays is None:
            return human, self._scored
        from aaai.scoring.replays import ReplaySaver

        saver = ReplaySaver(
            self.settings.replays,
            f"human:{self.player}",
            human,
            prefix=self.player,
            arenas={a.name: a for a in self.settings.arenas},
            on_episode=self._scored,
        )
        return saver.make_policy, saver.on_episode

    @staticmethod
    def _key_of(row: dict) -> tuple:
        if row.get("arena"):
            return ("arena", row["arena"], int(row["seed"]))
        return (int(row["level"]), int(row["difficulty"]), int(row["seed"]))

    @staticmethod
    def _key_of_episode(episode: tuple) -> tuple:
        level, difficulty, seed, arena = episode
        return ("arena", arena.name, seed) if arena is not None else (level, difficulty, seed)

    def _episode_reset(self, env) -> None:
        spec = env.level_spec
        arena = self.remaining[0][3] if self.remaining else None
        with self.cond:
            self.env, self.started, self.keys = env, False, set()
            self.episode = {
                "index": self.played + 1,
                "total": self.total,
                "label": get_level(spec.level).label,
                "level": spec.level,
                "name": spec.name,
                "title": get_level(spec.level).title,
                "task": task_of(spec.level, arena),
                "difficulty": spec.difficulty,
                "seed": spec.seed,
                "arena": arena.name if arena is not None else "",
                "max_steps": env.max_steps,
            }
            self.ready_at = max(self.ready_at, time.monotonic())
            self.force_frame = True
            self._changed()

    def _next_action(self, env, observation) -> np.ndarray:
        self._update(env, observation)
        with self.cond:
            if env.steps == 0 and self.phase == "loading":  # the start screen, over the level's first frame
                self._set_phase("ready")
                self._changed()
            while True:
                idle = self.settings.idle_seconds
                if self.abandon_reason is None and time.monotonic() - self.last_input > idle:
                    self.abandon_reason = f"no key was pressed for {idle:g} seconds (--idle)"
                if self.abandon_reason is not None:
                    raise Abandoned(self.abandon_reason)
                if self.phase == "running":
                    now = time.monotonic()
                    if now >= self.deadline:
                        self.deadline += env.control_dt
                        if now - self.deadline > MAX_LAG:  # behind: let the clock slip, do not race
                            self.deadline = now
                        controls = {CONTROL_KEYS[k] for k in self.keys}
                        return np.array(command_of(controls), np.float32)
                    self.cond.wait(self.deadline - now)
                else:
                    self.cond.wait(0.25)

    def _episode_end(self, env, result) -> None:
        self._update(env, result.observation, force=True)

    def _scored(self, row: dict) -> None:
        with self.cond:
            self.rows.append(row)
            self.played += 1
            self.remaining.pop(0)
            self.last = {
                key: row[key]
                for key in (
                    "level",
                    "level_name",
                    "difficulty",
                    "seed",
                    "arena",
                    "return",
                    "max_reward",
                    "ratio",
                    "outcome",
                    "steps",
                    "food_eaten",
                )
            }
            self.ready_at = time.monotonic() + self.settings.between_seconds
            self._set_phase("loading")
            self._changed()

    def _update(self, env, observation, force: bool = False) -> None:
        """The live figures after a step, and a frame if the page is ready for one."""
        spec, snapshot = env.level_spec, env.snapshot()
        head = snapshot.head
        controls = {CONTROL_KEYS[k] for k in self.keys}
        live = {
            "steps": env.steps,
            "max_steps": env.max_steps,
            "time_left": round(max(0, env.max_steps - env.steps) * env.control_dt, 2),
            "sim_time": round(snapshot.time, 3),
            "food_eaten": env.task.food_eaten,
            "pose": {
                "x": round(head.x, 3),
                "y": round(head.y, 3),
                "z": round(head.z, 3),
                "yaw_deg": round(float(np.degrees(head.yaw)), 1),
            },
            "command": list(command_of(controls)),
            "dark": bool(env.dark),
        }
        with self.cond:
            self.live = live
            now = time.monotonic()
            wanted = self.attached and (self.force_frame or (self.acked >= self.frame_no and now >= self.next_frame_at))
        if wanted:
            images = [
                encode(camera_image(observation["camera"]), ".png"),
                encode(draw_snapshot(spec, snapshot, self.settings.map_size), ".jpg"),
            ]
            with self.cond:
                self.frame_no += 1
                self.frame_data, self.force_frame = images, False
                interval = 1.0 / self.settings.max_fps  # frames due on a schedule, so 30 fps is 30, not 25
                self.next_frame_at = max(self.next_frame_at + interval, now - interval)
        with self.cond:
            self._changed()

    def _finish(self, message: str) -> None:
        with self.cond:
            self._set_phase("finished", message)
            self._changed()

    def _fail(self, message: str) -> None:
        with self.cond:
            self._set_phase("error", message)
            self._changed()

    def _write_abandoned(self) -> None:
        """The episode the player left, in <scoreboard>_abandoned.csv (not a score: the scoreboard
        does not have it, so the battery resumes at it); nothing if it had not started."""
        with self.cond:
            started, episode, live, reason = self.started, dict(self.episode), dict(self.live), self.abandon_reason
            self._set_phase("abandoned", f"abandoned: {reason}")
            self._changed()
        if not started or not episode:
            return
        path = abandoned_path(self.output)
        try:
            append_row(
                path,
                ABANDONED_COLUMNS,
                {
                    "player": self.player,
                    "level": episode["level"],
                    "level_name": episode["name"],
                    "difficulty": episode["difficulty"],
                    "seed": episode["seed"],
                    "arena": episode["arena"],
                    "steps": live.get("steps", 0),
                    "max_steps": episode["max_steps"],
                    "food_eaten": live.get("food_eaten", 0),
                    "reason": reason,
                    "utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
                },
            )
        except OSError as error:
            self._fail(f"cannot write {str(path)!r}: {error.strerror or error}; the episode left was not logged")

    # --- helpers (called holding the lock) ---------------------------------------------
    def _set_phase(self, phase: str, message: str = "") -> None:
        self.phase, self.message = phase, message

    def _pause(self, why: str) -> None:
        self.keys = set()
        if self.phase == "running":
            self._set_phase("paused", why)

    def _changed(self) -> None:
        self.version += 1
        self.cond.notify_all()
        try:
            self.notify()
        except RuntimeError:  # the page's event loop has closed: nobody to tell
            pass


def encode(image: np.ndarray, extension: str) -> bytes:
    """An RGB image as PNG or JPEG bytes."""
    params = [cv2.IMWRITE_JPEG_QUALITY, 85] if extension == ".jpg" else [cv2.IMWRITE_PNG_COMPRESSION, 1]
    ok, data = cv2.imencode(extension, cv2.cvtColor(image, cv2.COLOR_RGB2BGR), params)
    if not ok:
        raise RuntimeError(f"could not encode a frame as {extension}")
    return data.tobytes()


def abandoned_path(output: Path) -> Path:
    return output.with_name(output.stem + "_abandoned.csv")


def return_memory() -> None:
    """Gives the memory freed by closed environments back to the system (glibc's malloc_trim;
    without it the freed pages of a session's thread stay with the process)."""
    try:
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: its allocator keeps or returns memory as it does
        pass


__all__ = [
    "Abandoned",
    "HumanPolicy",
    "InputError",
    "PlaySettings",
    "Session",
    "KEYS",
    "CONTROL_KEYS",
    "abandoned_path",
    "check_player",
    "return_memory",
    "control_of",
    "command_of",
]
