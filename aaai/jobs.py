"""A long job's surroundings: its progress (rate, pass rate, ETA) and one torch thread per process.

Training and scoring both report through :class:`Progress`; it sits below both, so that scoring
uses it without importing the trainers.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from typing import Callable, ContextManager, Iterator, TextIO

Advance = Callable[[int], None]  # tells a report of steps (or episodes) done
Display = Callable[["Progress"], ContextManager[Advance]]  # shows a report while a job runs


class Progress:
    """How far a job of ``total`` steps is: steps done, their rate, episodes, the recent pass rate
    and the time left; with ``every`` seconds and ``write``, one such line every ``every`` seconds
    (for a log: piped or under nohup, where a progress bar prints nothing).

    The rate is measured over the updates of the last ``window`` seconds, from the first update
    on, so the start-up before the first step (worker processes, torch) does not count: counted,
    it made the ETA hours long at the start of a run of seconds.
    """

    def __init__(
        self,
        total: int,
        done: int = 0,
        label: str = "training",
        unit: str = "steps",
        every: float | None = None,
        write: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        window: float = 60.0,
        recent: int = 50,
    ):
        self.total, self.done, self.label, self.unit = total, done, label, unit
        self.every, self.write, self.clock, self.window = every, write, clock, window
        self.episodes = self.env_steps = 0
        self.started = clock()
        self.passes: deque[bool] = deque(maxlen=recent)
        self.marks: deque[tuple[float, int]] = deque()  # (time, steps done) of recent updates
        self.last_line = clock()

    def update(self, steps: int) -> None:
        self.done += steps
        now = self.clock()
        self.marks.append((now, self.done))
        while len(self.marks) > 2 and now - self.marks[1][0] >= self.window:
            self.marks.popleft()
        self.maybe_write(now)

    def add_episodes(self, passed: list[bool], steps: int = 0) -> None:
        """Finished episodes (whether each passed) and, when the unit is not steps, their steps."""
        self.episodes += len(passed)
        self.passes.extend(passed)
        self.env_steps += steps

    def rate(self) -> float | None:
        """Steps per second over the recent updates (None before two updates a moment apart)."""
        if len(self.marks) < 2:
            return None
        (t0, s0), (t1, s1) = self.marks[0], self.marks[-1]
        return (s1 - s0) / (t1 - t0) if t1 > t0 else None

    def eta(self) -> float | None:
        rate = self.rate()
        return max(self.total - self.done, 0) / rate if rate else None

    def details(self) -> str:
        """Everything but the count: rate, episodes (or steps), the recent pass rate, the ETA."""
        rate = self.rate()
        rate_text = "-" if rate is None else f"{rate:.0f}" if rate >= 10 else f"{rate:.2g}"
        if self.unit == "steps":
            count = f"{self.episodes} episodes"
        else:
            elapsed = self.clock() - self.started
            count = (
                f"{self.env_steps} steps ({self.env_steps / elapsed:.0f} steps/s)"
                if elapsed > 0
                else f"{self.env_steps} steps"
            )
        passed = (
            f"{100 * sum(self.passes) / len(self.passes):.0f}% of the last {len(self.passes)}" if self.passes else "-"
        )
        return f"{rate_text} {self.unit}/s, {count}, pass rate {passed}, ETA {format_duration(self.eta())}"

    def line(self) -> str:
        share = f" ({100 * self.done / self.total:.0f}%)" if self.total else ""
        return f"{self.label}: {self.done} / {self.total} {self.unit}{share}, {self.details()}"

    def maybe_write(self, now: float | None = None) -> None:
        now = self.clock() if now is None else now
        if self.write is not None and self.every is not None and now - self.last_line >= self.every:
            self.last_line = now
            self.write(self.line())


def format_duration(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours} h {rest // 60:02d} min" if hours else f"{rest // 60} min {rest % 60:02d} s"


def print_lines(stream: TextIO) -> Callable[[str], None]:
    def write(text: str) -> None:
        stream.write(text + "\n")
        stream.flush()

    return write


@contextlib.contextmanager
def quietly(report: Progress) -> Iterator[Advance]:
    """The :data:`Display` that shows nothing: ``report`` is only kept up to date (and writes its
    lines if it was given ``write`` and ``every``)."""
    yield report.update


def one_thread() -> None:
    """A worker scoring episodes uses one torch thread: a policy's small network gains nothing from
    more, and with the default (one per core) the workers fight over the cores (10x the CPU time)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)
