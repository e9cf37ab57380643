"""Many participants at once: N participants play a study's trial together over WebSockets, as pages do.

:func:`play_together` opens one socket per participant link (with the server's own Origin), joins,
consents, starts, holds a key through one trial and acknowledges every frame, as the participant
page does. Each page measures its own control steps per second in real time from the server's
``time_left`` (the steps it has left, times the control step): the steps between the trial's first
and last running frame over the wall-clock time between them. ``bench/study_load.py`` (the
sessions-per-core figure) and ``tests/test_study_load.py`` (the floor and the cap) use it.
"""

from __future__ import annotations

import asyncio
import json
import os
import time
from dataclasses import dataclass, field

from websockets.asyncio.client import connect

CONTROL_DT = 0.02  # seconds per control step: the study's sessions step at 50 Hz


@dataclass
class PageResult:
    """What one participant's page saw: its steps per second while running, and how its trial ended."""

    token: str
    steps: int = 0
    seconds: float = 0.0
    finished: bool = False
    refused: str = ""  # the server's message when it refused this participant
    frames: int = 0
    times: list[float] = field(default_factory=list)

    @property
    def rate(self) -> float:
        return self.steps / self.seconds if self.seconds > 0 else 0.0


async def play_one(port: int, token: str, timeout: float = 60.0) -> PageResult:
    """One participant's page: join, consent, start, hold 'forward' through the trial, ack each frame."""
    result = PageResult(token)
    origin = f"http://127.0.0.1:{port}"
    async with connect(f"ws://127.0.0.1:{port}/ws", origin=origin, max_size=None) as ws:  # type: ignore[arg-type]
        await ws.send(json.dumps({"type": "join", "token": token}))
        first: tuple[float, float] | None = None
        last: tuple[float, float] | None = None
        pressed = False
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                message = await asyncio.wait_for(ws.recv(), end - time.monotonic())
            except TimeoutError:
                break
            if isinstance(message, bytes):
                continue
            data = json.loads(message)
            kind = data["type"]
            if kind == "error":
                result.refused = data["message"]
                return result
            if kind == "joined":
                if not data["consented"]:
                    await ws.send(json.dumps({"type": "consent"}))
                await ws.send(json.dumps({"type": "start"}))
                continue
            if kind not in ("frame", "status"):
                continue
            if kind == "frame":
                result.frames += 1
                await ws.send(json.dumps({"type": "ack", "frame": data["frame"]}))
            phase = data["phase"]
            if phase == "ready" and data["accepts_start"] and not pressed:
                await ws.send(json.dumps({"type": "key", "key": "ArrowUp", "down": True}))
                pressed = True
            elif phase == "running" and data.get("time_left") is not None:
                now = (time.monotonic(), float(data["time_left"]))
                first = first or now
                last = now
            elif phase == "finished":
                result.finished = True
                break
            elif phase in ("error", "abandoned"):
                result.refused = data["message"]
                break
        if first is not None and last is not None and last[0] > first[0]:
            result.steps = round((first[1] - last[1]) / CONTROL_DT)
            result.seconds = last[0] - first[0]
    return result


async def _together(port: int, tokens: list[str], timeout: float) -> list[PageResult]:
    return list(await asyncio.gather(*(play_one(port, token, timeout) for token in tokens)))


def play_together(port: int, tokens: list[str], timeout: float = 60.0) -> list[PageResult]:
    """Every token's participant plays at once (one event loop, one socket each); their results, in order."""
    return asyncio.run(_together(port, tokens, timeout))


def cpu_seconds(pid: int) -> float:
    """The CPU time (user + system, seconds) process ``pid`` has used so far, from /proc (Linux)."""
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


__all__ = ["CONTROL_DT", "PageResult", "cpu_seconds", "play_one", "play_together"]
