"""One participant's trials, played in a browser on the ``aaai play`` session machinery.

:class:`StudySession` is an :class:`aaai.tools.play.session.Session` (the same keys, real-time
clock, pause on a lost focus or a dropped tab) whose battery is the participant's unfinished
trials from the store, in their order. Each trial is one episode, recorded as a replay; its row
and replay are committed to the store before the next trial starts, so a killed server loses no
finished trial and the participant resumes at the unfinished one. Each attempt at a trial (from its
first step) is kept in the store with its progress; one left unfinished is recorded as abandoned
(with why) and the trial is played again. What the page is told
(:meth:`StudySession.participant_status`) leaves out the map, coordinates, seed, returns and file
names unless the study shows them.
"""

from __future__ import annotations

import traceback
from typing import Callable

from aaai.config import ConfigError, env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.scoring.episodes import run_episode
from aaai.scoring.replays import Recorder, with_arena
from aaai.study.paths import Odometer
from aaai.study.store import Store, trial_of
from aaai.study.studyfile import Study
from aaai.tools.play.session import Abandoned, HumanPolicy, PlaySettings, Session

PROGRESS_STEPS = 25  # an attempt's progress is saved every 25 control steps (0.5 s of play)

FEEDBACK = {
    "found": "You found the food!",
    "time": "Time is up.",
    "fell": "Oops, you fell. On to the next one.",
    "other": "That round is over.",
}


def play_settings(study: Study, grace_seconds: float = 60.0, max_fps: float = 30.0) -> PlaySettings:
    """The play settings of a study's sessions: gait mode, one control step per action, the camera at
    the study's resolution, and each trial as long as the study's time limit (or its level's own)."""
    overrides: dict = {"camera": True, "camera_resolution": study.camera_resolution, "action_mode": "gait"}
    config = load_config(None, **overrides)
    control_dt = config.physics.control_dt
    changes: dict = {"decision_interval": control_dt}
    if study.time_limit is not None:
        changes["max_steps"] = max(1, round(study.time_limit / control_dt))
    return PlaySettings(
        config=load_config(config, **changes),
        grace_seconds=grace_seconds,
        max_fps=max_fps,
        map_size=240 if study.show["map"] else 64,
        between_seconds=1.0,
    )


def feedback_of(row: dict, end: str | None) -> str:
    """What a participant is told after a trial, in plain words."""
    if row["outcome"] in ("passed", "succeeded") or (end == "ate green" and row["food_eaten"]):
        return FEEDBACK["found"]
    if end == "fell":
        return FEEDBACK["fell"]
    if end == "time" or end is None:
        return FEEDBACK["time"]
    return FEEDBACK["other"]


def first_move(actions: list[list[float]], control_dt: float) -> float | None:
    """Seconds from a trial's start to its first step with a key held (None: never moved)."""
    for step, action in enumerate(actions):
        if any(action):
            return round(step * control_dt, 3)
    return None


class StudySession(Session):
    """A participant's session: their unfinished trials, each committed to the store as it ends."""

    def __init__(
        self,
        settings: PlaySettings,
        study: Study,
        store: Store,
        participant: str,
        notify: Callable[[], None] = lambda: None,
        on_end: Callable[[Session], None] | None = None,
    ):
        super().__init__(settings, participant, notify, on_end)
        self.study, self.store, self.pid = study, store, participant
        self.planned: list[dict] = []  # the unfinished trials, in order (the first is the current one)
        self.battery_total = len(study.battery)
        self.battery_done = 0
        self.feedback = ""
        self.show_break = False
        self.control_dt = settings.config.physics.control_dt
        self.odometer = Odometer(self.control_dt)
        self.attempt: int | None = None  # the number of the attempt in play (its clock started), if any

    def _play(self) -> None:
        try:
            trials = self.store.trials(self.pid)
            self.planned = [t for t in trials if t["finished"] is None]
            self.battery_done = sum(t["kind"] == "battery" and t["finished"] is not None for t in trials)
            self.total, self.played = len(trials), len(trials) - len(self.planned)
            self.remaining = [self._episode_of(t) for t in self.planned]
            if self.planned:
                self._play_trials()
            self.store.finish(self.pid)
            self._finish(self.study.texts["completion"])
        except Abandoned as left:
            self._end_attempt(str(left))
            with self.cond:
                self._set_phase("abandoned", str(left))
                self._changed()
        except ConfigError as error:
            self._end_attempt(f"the server failed: {error}")
            self._fail(str(error))
        except Exception as error:  # noqa: BLE001 - this participant's page is told; the others play on
            traceback.print_exc()
            self._end_attempt(f"the server failed: {type(error).__name__}: {error}")
            self._fail(f"{type(error).__name__}: {error}")

    @staticmethod
    def _episode_of(trial: dict) -> tuple:
        spec = trial_of(trial)
        return (spec.level, spec.difficulty, spec.seed, spec.arena)

    def _play_trials(self) -> None:
        env = AnimalAIEnv(config=env_part(self.settings.config, shaping=0.0))
        try:
            recorder = Recorder(env, HumanPolicy(self, env), f"human:{self.pid}")
            while self.planned:
                trial = self.planned[0]
                level, difficulty, seed, arena = self._episode_of(trial)
                row = run_episode(env, recorder, level or 0, difficulty or 0, seed, arena)
                replay = with_arena(recorder.last or {}, arena)
                reaction = first_move(recorder.actions, env.control_dt)
                path, seconds = self.odometer.metres, round(row["steps"] * env.control_dt, 3)
                self.store.finish_trial(self.pid, trial["position"], row, replay, reaction, path, seconds)  # durable
                self.attempt = None
                self.planned.pop(0)
                self.battery_done += trial["kind"] == "battery"
                self.feedback = feedback_of(row, replay.get("end"))
                self._scored(row)
        finally:
            env.close()

    def _episode_reset(self, env) -> None:
        trial = self.planned[0]
        self.store.start_trial(self.pid, trial["position"])
        breaks = self.study.breaks_every
        self.show_break = bool(
            trial["kind"] == "battery" and breaks and self.battery_done and self.battery_done % breaks == 0
        )
        first_battery = trial["kind"] == "battery" and self.battery_done == 0 and bool(self.study.practice)
        self.odometer.reset()
        super()._episode_reset(env)
        with self.cond:
            self.episode.update(kind=trial["kind"], position=trial["position"], first_battery=first_battery)
            self._changed()

    def _next_action(self, env, observation):
        """``Session``'s (the keys' command when the clock says so); the trial's attempt begins with
        its first step, and its progress is saved every PROGRESS_STEPS steps."""
        action = super()._next_action(env, observation)
        position = self.planned[0]["position"]
        if self.attempt is None:
            self.attempt = self.store.begin_attempt(self.pid, position)
        elif env.steps % PROGRESS_STEPS == 0:
            self.store.save_attempt(self.pid, position, self.attempt, self._progress())
        return action

    def _progress(self) -> dict:
        """How far the attempt in play got: steps, seconds, food eaten and path (m)."""
        with self.cond:
            steps, food = int(self.live.get("steps", 0)), int(self.live.get("food_eaten", 0))
        return {
            "steps": steps,
            "seconds": round(steps * self.control_dt, 3),
            "food_eaten": food,
            "path_m": self.odometer.metres,
        }

    def _end_attempt(self, reason: str) -> None:
        """The attempt in play (if its clock started) recorded as abandoned, with how far it got and why."""
        if self.attempt is None or not self.planned:
            return
        attempt, self.attempt = self.attempt, None
        try:
            self.store.save_attempt(
                self.pid, self.planned[0]["position"], attempt, self._progress(), "abandoned", reason
            )
        except Exception:  # noqa: BLE001 - the store failed: it stays playing, interrupted at the next start
            traceback.print_exc()

    def _update(self, env, observation, force: bool = False) -> None:
        """The page's figures and frame (``Session``'s), and the trunk's position on the trial's path."""
        position, _ = env.body.head_pose()
        if force:  # the trial's end
            self.odometer.end(float(position[0]), float(position[1]))
        else:
            self.odometer.at(env.steps, float(position[0]), float(position[1]))
        super()._update(env, observation, force)

    def participant_status(self) -> dict:
        """What the participant's page is told: the phase, the progress, the feedback; the map's
        absence is the server's (it sends the camera only); coordinates, seed and returns only if shown."""
        status = self.status()
        episode = status["episode"]
        show = self.study.show
        out = {
            "phase": status["phase"],
            "accepts_start": status["accepts_start"],
            "version": status["version"],
            "time_left": status.get("time_left"),
            "kind": episode.get("kind", ""),
            "progress": {"done": self.battery_done, "total": self.battery_total},
            "break": self.show_break,
            "first_battery": bool(episode.get("first_battery")),
            "feedback": self.feedback,
            "message": status["message"] if status["phase"] != "error" else "Something went wrong on our side.",
        }
        if show["coordinates"] and "pose" in status:
            out["pose"] = status["pose"]
        if show["seed"] and episode:
            out["trial"] = {k: episode.get(k) for k in ("label", "difficulty", "seed", "arena")}
        if show["returns"] and status["last"]:
            out["last"] = {k: status["last"][k] for k in ("return", "max_reward", "outcome")}
        return out


__all__ = ["FEEDBACK", "StudySession", "feedback_of", "first_move", "play_settings"]
