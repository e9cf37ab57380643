"""The ``aaai play`` web server: FastAPI and uvicorn, one WebSocket per browser tab.

``GET /`` is the page (aaai/tools/play/static), ``GET /api/sessions`` the state of every session (for
watching a study, and for tests), ``/ws`` the socket a page plays through. The socket's messages
are JSON text; the page sends

    {"type": "join", "player": NAME[, "token": T]}   take a player's battery (the token re-attaches a dropped tab)
    {"type": "key", "key": KEY, "down": true|false}  a key pressed or released (aaai.tools.play.session.KEYS)
    {"type": "focus", "focused": true|false}          the page gained or lost focus (losing it pauses)
    {"type": "ack", "frame": N}                       frame N is on screen: the next may come

and gets ``hello``, ``joined``, ``status`` (phase, episode, time left, food, pose, ...), ``frame``
(the status with a frame number, then two binary messages: the camera as PNG and the map as JPEG)
and ``error`` messages. A bad message gets an ``error`` naming what was wrong and changes nothing.

Each tab's session is its own (its own environment, thread and scoreboard rows); a player name is
held by one socket at a time, and a dropped tab can come back (with its token) within the grace
period, after which its episode is abandoned. A page that joins with the token while the old
socket is still open (a reload whose old socket has not closed yet) takes the session over: the old
socket is told and closed (code :data:`TAKEN_OVER`), and nothing it sends after that counts.
At most ``max_sessions`` sessions hold an environment at once (:func:`default_max_sessions`); a
session whose battery is over and whose tab is gone is dropped, its memory given back; one where no
key is pressed for ``idle_seconds`` (``--idle``) is abandoned.

Nothing reaches the app that is not from the server's own page, by its own address, and (on a
network) with its token: :class:`aaai.tools.play.guard.Guard`.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import json
import secrets
import socket
import threading
from collections.abc import AsyncIterator, Callable
from importlib import resources
from typing import Any, TypeVar

from fastapi import FastAPI, WebSocket, WebSocketDisconnect
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

from aaai.config import ConfigError
from aaai.tools.play.guard import WILDCARDS, Guard, is_loopback, link_host, own_hosts, shown
from aaai.tools.play.session import (
    CONTROL_KEYS,
    GO_KEYS,
    KEYS,
    InputError,
    PlaySettings,
    Session,
    check_player,
    return_memory,
)

MAX_MESSAGE_CHARS = 1000
MESSAGE_TYPES = ("join", "key", "focus", "ack")
# Sessions one core of a server holds at 50 control steps a second with the camera at 84 px
# (bench/study_load.py, bench/study_load.md; docs/play.md, "Many participants at once"): a session
# costs the server 0.14 to 0.20 CPU seconds per second of play (0.20 alone): 0.9 / 0.20 = 4.5 on the
# machine the bench ran on, where 4 at once held 49.9 steps/s. On a slower shared machine (the CI's,
# 2026-11-27) 4 at once held 40.5 to 46.1, so the default is 3, which leaves a quarter of a core spare.
SESSIONS_PER_CORE = 3
# The cores one server uses: its sessions are threads of one Python process, which runs Python on
# one core at a time (8 and 10 sessions took 0.97 and 1.03 cores with the second core free, 44 and 40 steps/s).
SERVER_CORES = 1
SESSION_MEGABYTES = 50  # a session's environment, camera and thread take 37 to 48 MB (docs/play.md)
TAKEN_OVER = 4409  # the close code of a socket whose session another page (with its token) took over


def available_megabytes() -> float | None:
    """The memory the system could give (MemAvailable, Linux), or None where unknown."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return None


def default_max_sessions() -> int:
    """--max-sessions of ``aaai play`` and ``aaai study serve`` by default:
    :data:`SESSIONS_PER_CORE` times the :data:`SERVER_CORES` one server process uses (whatever the
    machine has), and no more than half the available memory holds at 50 MB a session."""
    cap = SESSIONS_PER_CORE * SERVER_CORES
    memory = available_megabytes()
    if memory is not None:
        cap = min(cap, int(memory / 2 / SESSION_MEGABYTES))
    return max(1, cap)


def deliver(session: Session, data: dict) -> None:
    """A page's input message, checked by :func:`parse_message`, given to its session: a key pressed
    or released, the page's focus, or a frame acknowledged."""
    if data["type"] == "key":
        session.key(data.get("key"), data["down"])
    elif data["type"] == "focus":
        session.focus(data["focused"])
    else:
        session.ack(data["frame"])


class Registry:
    """The server's sessions by player name; thread-safe."""

    def __init__(self, settings: PlaySettings):
        self.settings = settings
        self.max_sessions = settings.max_sessions or default_max_sessions()
        self.lock = threading.Lock()
        self.sessions: dict[str, Session] = {}
        self.generation: dict[str, int] = {}  # bumped on every attach, so that a stale expiry does nothing
        self.evictors: dict[str, Callable[[], None]] = {}  # how to close the socket that holds a player

    def join(
        self, name: object, token: str | None, notify, evict: Callable[[], None] = lambda: None
    ) -> tuple[Session, int]:
        """The session of the player a page names (``name``, any value from the page: checked here),
        and the generation its socket holds it at (:meth:`holds`). With the session's token, a page
        takes over a session another socket still holds: ``evict`` of that socket is called."""
        player = check_player(name)
        if self.settings.player is not None and player != self.settings.player:
            raise InputError(f"player: got {player!r}; this server plays only {self.settings.player!r} (--player)")
        with self.lock:
            session = self.sessions.get(player)
            if session is not None and session.phase in ("finished", "error", "abandoned") and not session.attached:
                session = None  # over: a new tab starts the player's battery again (resuming its scoreboard)
            if session is None:
                live = self.live()
                if live >= self.max_sessions:
                    raise InputError(
                        f"the server is full: {live} player{'s' * (live != 1)} "
                        f"{'are' if live != 1 else 'is'} playing (--max-sessions {self.max_sessions}); "
                        "try again when one has finished"
                    )
                session = Session(self.settings, player, notify, on_end=self.ended)
                self.sessions[player] = session
                self.generation[player] = 1
                self.evictors[player] = evict
                session.start()
                return session, 1
            if token != session.token:
                raise InputError(
                    f"player {player!r} is playing in another tab; one tab per player (their episodes "
                    "go to one scoreboard): choose another name, or close that tab"
                )
            if session.attached:  # the same page reloaded before its old socket closed (or a duplicated tab)
                self.evictors.get(player, lambda: None)()
            self.generation[player] += 1
            self.evictors[player] = evict
            session.attach(notify)
            return session, self.generation[player]

    def holds(self, session: Session, generation: int) -> bool:
        """Whether the socket that joined ``session`` at ``generation`` still holds it."""
        with self.lock:
            return self.sessions.get(session.player) is session and self.generation.get(session.player) == generation

    def live(self) -> int:
        """Sessions holding an environment (their battery not over); call holding the lock."""
        return sum(not session.done.is_set() for session in self.sessions.values())

    def detach(self, session: Session, generation: int) -> None:
        """The socket that holds ``session`` at ``generation`` closed (one taken over holds nothing)."""
        with self.lock:
            if self.generation.get(session.player) != generation or self.sessions.get(session.player) is not session:
                return
            session.detach()
            self.evictors.pop(session.player, None)
            gone = session.done.is_set() and self._forget(session)  # over already: nothing to come back to
        if gone:
            return_memory()

    def expire(self, session: Session, generation: int) -> None:
        """The grace period of a dropped tab is over: abandon its episode unless it came back."""
        with self.lock:
            current = self.sessions.get(session.player) is session and self.generation.get(session.player) == generation
            if current and not session.attached:
                session.abandon("the tab was closed (or lost its connection) mid-battery")

    def ended(self, session: Session) -> None:
        """A session's battery is over (on its thread): forgotten now unless a tab still shows it
        (then when that tab goes), and the memory of its environment given back."""
        with self.lock:
            gone = self._forget(session)
        if gone:
            return_memory()

    def _forget(self, session: Session) -> bool:
        """Drops an over session whose tab is gone; call holding the lock."""
        if session.attached or self.sessions.get(session.player) is not session:
            return False
        del self.sessions[session.player]
        self.generation.pop(session.player, None)
        self.evictors.pop(session.player, None)
        return True

    def all(self) -> list[Session]:
        with self.lock:
            return list(self.sessions.values())

    def close(self, reason: str = "the server stopped", timeout: float = 5.0) -> None:
        sessions = self.all()
        for session in sessions:
            session.abandon(reason)
        for session in sessions:
            session.thread.join(timeout)


def parse_message(text: Any) -> dict:
    """A page's message, checked: InputError names what is wrong."""
    if not isinstance(text, str):
        raise InputError("message: got a binary message; allowed: JSON text")
    if len(text) > MAX_MESSAGE_CHARS:
        raise InputError(f"message: got {len(text)} characters; allowed: at most {MAX_MESSAGE_CHARS}")
    try:
        data = json.loads(text)
    except ValueError:
        raise InputError(
            f'message: got {text[:60]!r}, which is not JSON; allowed: a JSON object with a "type"'
        ) from None
    if not isinstance(data, dict) or data.get("type") not in MESSAGE_TYPES:
        shown = data.get("type") if isinstance(data, dict) else data
        raise InputError(f"message type: got {shown!r}; allowed: {', '.join(MESSAGE_TYPES)}")
    kind = data["type"]
    if kind == "key" and not isinstance(data.get("down"), bool):
        raise InputError(f"key message: 'down' got {data.get('down')!r}; allowed: true or false")
    if kind == "focus" and not isinstance(data.get("focused"), bool):
        raise InputError(f"focus message: 'focused' got {data.get('focused')!r}; allowed: true or false")
    if kind == "ack" and (not isinstance(data.get("frame"), int) or isinstance(data.get("frame"), bool)):
        raise InputError(f"ack message: 'frame' got {data.get('frame')!r}; allowed: a frame number")
    if kind == "join" and data.get("token") is not None and not isinstance(data["token"], str):
        raise InputError(f"join message: 'token' got {data['token']!r}; allowed: the token a 'joined' message gave")
    return data


def hello(settings: PlaySettings) -> dict:
    return {
        "type": "hello",
        "keys": list(KEYS),
        "controls": CONTROL_KEYS,
        "start_keys": list(GO_KEYS),
        "player": settings.player,
        "episodes": len(settings.episodes()),
    }


def create_app(
    settings: PlaySettings, hosts: list[str], token: str | None = None, cookie: str = "aaai_play"
) -> FastAPI:
    """The app: its page, its API and its socket, behind the Guard (``hosts``: the Host values it
    answers to; ``token``: the one every request must carry, on a network)."""
    registry = Registry(settings)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        yield
        await asyncio.get_running_loop().run_in_executor(None, registry.close)

    app = FastAPI(title="aaai play", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.add_middleware(Guard, hosts=hosts, token=token, cookie=cookie)
    app.state.registry = registry
    static = resources.files("aaai.tools.play") / "static"

    @app.get("/", response_class=HTMLResponse)
    def page() -> str:
        return (static / "index.html").read_text()

    app.mount("/static", StaticFiles(directory=str(static)), name="static")

    @app.get("/api/sessions")
    def sessions() -> JSONResponse:
        return JSONResponse([session.status() for session in registry.all()])

    @app.websocket("/ws")
    async def play_socket(websocket: WebSocket) -> None:
        await websocket.accept()
        loop = asyncio.get_running_loop()
        wake = asyncio.Event()
        sending = asyncio.Lock()
        session: Session | None = None
        held = 0  # the generation this socket holds its session at
        sender: asyncio.Task | None = None
        leaving: list[asyncio.Task] = []

        def notify() -> None:
            loop.call_soon_threadsafe(wake.set)

        async def leave() -> None:
            """Another page took this socket's session over: say so, and close."""
            if sender is not None:
                sender.cancel()
            assert session is not None
            message = f"player {session.player!r} was taken over by another page (a reload or a duplicated tab)"
            with contextlib.suppress(Exception):  # the socket may be closing already
                await send({"type": "error", "message": message})
                await websocket.close(code=TAKEN_OVER, reason="taken over by another page")

        def evict() -> None:  # called on this loop, inside another socket's join
            leaving.append(loop.create_task(leave()))

        async def send(data: dict) -> None:
            async with sending:
                await websocket.send_text(json.dumps(data))

        async def send_updates(session: Session) -> None:
            """Sends the newest frame the page has not had (one at a time: the page acknowledges
            each), or the status when only that changed."""
            sent_version, sent_frame = -1, -1
            while True:
                await wake.wait()
                wake.clear()
                frame = session.frame()
                status = session.status()  # its "version" says which changes it shows
                async with sending:
                    if frame is not None and frame[0] != sent_frame:
                        await websocket.send_text(json.dumps({"type": "frame", **status, "frame": frame[0]}))
                        for image in frame[1]:
                            await websocket.send_bytes(image)
                        sent_frame = frame[0]
                    elif status["version"] != sent_version:
                        await websocket.send_text(json.dumps({"type": "status", **status}))
                    sent_version = status["version"]

        await send(hello(settings))
        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect" or leaving:
                    break
                try:
                    data = parse_message(message.get("text", message.get("bytes")))
                    if data["type"] == "join":
                        if session is not None:
                            raise InputError(f"join: this page plays {session.player!r} already")
                        session, held = registry.join(data.get("player"), data.get("token"), notify, evict)
                        await send(
                            {
                                "type": "joined",
                                "player": session.player,
                                "token": session.token,
                                "output": str(session.output),
                            }
                        )
                        sender = asyncio.create_task(send_updates(session))
                        notify()
                    elif session is None:
                        raise InputError(f"{data['type']} message before join; allowed first: join")
                    else:
                        deliver(session, data)
                except InputError as error:
                    await send({"type": "error", "message": str(error)})
        except WebSocketDisconnect:
            pass
        finally:
            if sender is not None:
                sender.cancel()
            if session is not None and registry.holds(session, held):
                registry.detach(session, held)
                loop.call_later(settings.grace_seconds, registry.expire, session, held)

    return app


def bind(host: str, port: int) -> socket.socket:
    """A listening socket, or a ConfigError saying the port is taken (or the host unknown)."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as error:
        raise ConfigError(f"--host: got {host!r}, which is not an address of this machine ({error.strerror})") from None
    family, kind, proto, _, address = infos[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(address)
    except OSError as error:
        sock.close()
        if error.errno == errno.EADDRINUSE:
            raise ConfigError(
                f"--port: got {port}, and {host}:{port} is in use (another aaai play?); allowed: a free "
                "port, e.g. --port 8001, or --port 0 for any free one"
            ) from None
        raise ConfigError(f"--host/--port: cannot listen on {host}:{port}: {error.strerror}") from None
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


Served = TypeVar("Served", bound="Serving")


class Serving:
    """An app served by uvicorn on the bound socket ``sock``, in this thread (``run``) or a
    background one (``start``, which returns once it listens); ``stop`` ends it."""

    sock: socket.socket
    thread_name = "aaai-server"

    def serve(self, app: FastAPI) -> None:
        """Sets the app to serve on ``self.sock``."""
        import uvicorn

        self.app = app
        self.server = uvicorn.Server(
            uvicorn.Config(app, log_level="warning", ws="websockets-sansio", ws_max_size=1 << 16, lifespan="on")
        )
        self.thread: threading.Thread | None = None

    def run(self) -> None:
        try:
            self.server.run(sockets=[self.sock])
        finally:
            self.sock.close()

    def start(self: Served) -> Served:
        self.thread = threading.Thread(target=self.run, name=self.thread_name, daemon=True)
        self.thread.start()
        while not self.server.started and self.thread.is_alive():
            threading.Event().wait(0.02)
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        if self.thread is not None:
            self.thread.join(10)


class Server(Serving):
    """The app served on a socket by uvicorn in this thread (``run``) or a background one (``start``).

    On loopback (``host`` 127.0.0.1, localhost, ::1) ``url`` is the page's address; on a network
    the server has a random token and ``url`` carries it (``?token=...``), as ``local_url`` does
    for a browser on this machine."""

    thread_name = "aaai-play-server"

    def __init__(self, settings: PlaySettings, host: str = "127.0.0.1", port: int = 8000):
        self.sock = bind(host, port)
        self.port = self.sock.getsockname()[1]
        self.network = not is_loopback(host)
        self.token = secrets.token_urlsafe(24) if self.network else None
        query = f"?token={self.token}" if self.token else ""
        bound = self.sock.getsockname()[0]
        local = shown(bound) if bound not in WILDCARDS else "127.0.0.1" if bound == "0.0.0.0" else "[::1]"
        self.url = f"http://{link_host(host) if self.network else local}:{self.port}/{query}"
        self.local_url = f"http://{local}:{self.port}/{query}" if host in WILDCARDS else self.url
        self.serve(create_app(settings, own_hosts(host, self.port), self.token, cookie=f"aaai_play_{self.port}"))

    @property
    def registry(self) -> Registry:
        return self.app.state.registry
