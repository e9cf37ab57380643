"""``aaai study serve``: the participant pages of a study, on the ``aaai play`` server's machinery.

``GET /?p=TOKEN`` is a participant's page (``static/study.html``); a link that is unknown gets a
plain 404 page, a finished one a plain 403 page ("you have already taken part"). ``/ws`` is the
socket the page plays through: the ``aaai play`` messages (``key``, ``focus``, ``ack``, checked by
:func:`aaai.tools.play.server.parse_message`) and three of its own:

    {"type": "join", "token": T}   the participant of the link (answered with ``joined``: texts, progress)
    {"type": "consent"}            the participant agreed to the consent text (recorded in the store)
    {"type": "start"}              begin or continue the trials

The server sends ``status`` and ``frame`` messages with :meth:`StudySession.participant_status`
only, and only the camera image (the map too if the study shows it). A participant is held by
one tab at a time; a closed tab comes back with the same link (within the grace period it carries
on in the same session, later a new session resumes at the unfinished trial). Every request
passes :class:`aaai.tools.play.guard.Guard` (Host and Origin; ``public_url``: a TLS proxy's address
too). At most ``max_sessions`` participants play at once (:func:`default_max_sessions`, measured by
``bench/study_load.py``); one more gets the page (503) or message "The study is full right now".
"""

from __future__ import annotations

import asyncio
import contextlib
import html
import json
import threading
from collections.abc import AsyncIterator
from importlib import resources
from typing import Any

from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

from aaai.study.participant import StudySession
from aaai.study.store import Store
from aaai.study.studyfile import Study
from aaai.tools.play.guard import Guard, is_loopback, link_host, own_hosts
from aaai.tools.play.server import (
    MAX_MESSAGE_CHARS,
    Serving,
    bind,
    default_max_sessions,
    deliver,
    parse_message,
)
from aaai.tools.play.session import CONTROL_KEYS, GO_KEYS, InputError, PlaySettings, Session, return_memory

STUDY_MESSAGES = ("join", "consent", "start")
ENDED = ("finished", "error", "abandoned")
FULL_TITLE = "The study is full right now"
FULL_TEXT = "Too many people are taking part at this moment. Please try again in a few minutes."


def public_origin(url: str) -> str:
    """The origin (scheme://host[:port]) of --public-url, the address participants open through a
    proxy; a value that is not one gets a ValueError naming it and what is allowed."""
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname or parts.path not in ("", "/"):
        raise ValueError(
            f"--public-url: got {url!r}; allowed: the address participants open, scheme and host only, "
            "such as https://study.example.org"
        )
    if parts.query or parts.fragment or parts.username or parts.password:
        raise ValueError(f"--public-url: got {url!r}; allowed: scheme, host and port only (no query, user)")
    return f"{parts.scheme}://{parts.netloc.lower()}"


def plain_page(title: str, text: str, status: int) -> HTMLResponse:
    body = (
        '<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{0}</title>'
        '<link rel="stylesheet" href="/static/study.css"></head><body class="plain"><main id="plain">'
        "<h1>{0}</h1><p>{1}</p></main></body></html>"
    ).format(html.escape(title), html.escape(text))
    return HTMLResponse(body, status_code=status)


class StudyRegistry:
    """The live sessions by participant id; thread-safe."""

    def __init__(self, study: Study, store: Store, settings: PlaySettings, max_sessions: int | None = None):
        self.study, self.store, self.settings = study, store, settings
        self.max_sessions = max_sessions or default_max_sessions()
        self.lock = threading.Lock()
        self.sessions: dict[str, StudySession] = {}
        self.generation: dict[str, int] = {}

    def participant(self, token: object) -> dict:
        if not isinstance(token, str) or not 0 < len(token) <= 100:
            raise InputError("this link is not complete: open the link you were given")
        found = self.store.participant(token)
        if found is None:
            raise InputError("this link is not valid: open the link you were given")
        return found

    def start(self, pid: str, notify) -> StudySession:
        """The participant's session: the live one (re-attached) or a new one from the store."""
        with self.lock:
            session = self.sessions.get(pid)
            if session is not None and session.attached:
                raise InputError("this link is open in another tab or window: close it, then reload this page")
            if session is not None and session.phase not in ENDED:
                self.generation[pid] += 1
                session.attach(notify)
                return session
            if self.full():
                raise InputError(f"{FULL_TITLE}. {FULL_TEXT}")
            session = StudySession(self.settings, self.study, self.store, pid, notify, on_end=self.ended)
            self.sessions[pid], self.generation[pid] = session, 1
            session.start()
            return session

    def full(self, pid: str | None = None) -> bool:
        """Whether a new session would be one beyond the cap (a participant whose session is live is not new)."""
        session = self.sessions.get(pid) if pid is not None else None
        if session is not None and session.phase not in ENDED:
            return False
        return sum(not s.done.is_set() for s in self.sessions.values()) >= self.max_sessions

    def detach(self, session: StudySession) -> int:
        with self.lock:
            session.detach()
            if session.done.is_set() and self.sessions.get(session.pid) is session:
                del self.sessions[session.pid]  # over, and its tab gone: nothing to come back to
            return self.generation.get(session.pid, 0)

    def expire(self, session: StudySession, generation: int) -> None:
        with self.lock:
            if self.sessions.get(session.pid) is session and self.generation.get(session.pid) == generation:
                if not session.attached:
                    session.abandon("the tab was closed")

    def ended(self, session: Session) -> None:
        with self.lock:
            if isinstance(session, StudySession) and self.sessions.get(session.pid) is session and not session.attached:
                del self.sessions[session.pid]
        return_memory()

    def all(self) -> list[StudySession]:
        with self.lock:
            return list(self.sessions.values())

    def close(self, timeout: float = 5.0) -> None:
        sessions = self.all()
        for session in sessions:
            session.abandon("the server stopped")
        for session in sessions:
            session.thread.join(timeout)


def parse_study_message(text: Any) -> dict:
    """A page's message: the study's own (join, consent, start) or one of ``aaai play``'s."""
    if isinstance(text, str) and len(text) <= MAX_MESSAGE_CHARS:
        try:
            data = json.loads(text)
        except ValueError:
            data = None
        if isinstance(data, dict) and data.get("type") in STUDY_MESSAGES:
            return data
    return parse_message(text)


def create_study_app(
    study: Study,
    store: Store,
    settings: PlaySettings,
    hosts: list[str],
    max_sessions: int | None = None,
    origins: list[str] | None = None,
) -> FastAPI:
    registry = StudyRegistry(study, store, settings, max_sessions)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        yield
        await asyncio.get_running_loop().run_in_executor(None, registry.close)

    app = FastAPI(title=f"aaai study {study.name}", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.add_middleware(Guard, hosts=hosts, origins=origins)
    app.state.registry = registry
    static = resources.files("aaai.tools.play") / "static"

    @app.get("/", response_class=HTMLResponse)
    def page(request: Request) -> HTMLResponse:
        token = request.query_params.get("p")
        found = store.participant(token) if token and len(token) <= 100 else None
        if found is None:
            return plain_page("This link is not valid", "Please open the exact link you were given.", 404)
        if found["status"] == "finished":
            return plain_page(
                "You have already taken part",
                "You have finished this study already, and each link can be used once. Thank you for taking part!",
                403,
            )
        with registry.lock:
            full = registry.full(found["id"])
        if full:
            return plain_page(FULL_TITLE, FULL_TEXT, 503)
        return HTMLResponse((static / "study.html").read_text(), headers={"Cache-Control": "no-store"})

    app.mount("/static", StaticFiles(directory=str(static)), name="static")

    @app.get("/api/sessions")
    def sessions() -> JSONResponse:
        return JSONResponse({s.pid: s.participant_status() for s in registry.all()})

    @app.websocket("/ws")
    async def study_socket(websocket: WebSocket) -> None:
        await websocket.accept()
        loop = asyncio.get_running_loop()
        wake, sending = asyncio.Event(), asyncio.Lock()
        participant: dict | None = None
        session: StudySession | None = None
        sender: asyncio.Task | None = None

        def notify() -> None:
            loop.call_soon_threadsafe(wake.set)

        async def send(data: dict) -> None:
            async with sending:
                await websocket.send_text(json.dumps(data))

        async def send_updates(session: StudySession) -> None:
            sent_version, sent_frame = -1, -1
            images = 2 if study.show["map"] else 1
            while True:
                await wake.wait()
                wake.clear()
                frame = session.frame()
                status = session.participant_status()
                async with sending:
                    if frame is not None and frame[0] != sent_frame:
                        await websocket.send_text(json.dumps({"type": "frame", **status, "frame": frame[0]}))
                        for image in frame[1][:images]:
                            await websocket.send_bytes(image)
                        sent_frame = frame[0]
                    elif status["version"] != sent_version:
                        await websocket.send_text(json.dumps({"type": "status", **status}))
                    sent_version = status["version"]

        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect":
                    break
                try:
                    data = parse_study_message(message.get("text", message.get("bytes")))
                    kind = data["type"]
                    if kind == "join":
                        if participant is not None:
                            raise InputError("join: this page has joined already")
                        found = registry.participant(data.get("token"))
                        if found["status"] == "finished":
                            raise InputError("you have finished this study already; thank you for taking part")
                        participant = found
                        done = sum(
                            t["finished"] is not None and t["kind"] == "battery" for t in store.trials(found["id"])
                        )
                        await send(
                            {
                                "type": "joined",
                                "participant": found["id"],
                                "consented": found["status"] != "new",
                                "resuming": found["status"] == "started",
                                "texts": study.texts,
                                "progress": {"done": done, "total": len(study.battery)},
                                "practice": len(study.practice),
                                "breaks_every": study.breaks_every,
                                "show": study.show,
                                "controls": CONTROL_KEYS,
                                "start_keys": list(GO_KEYS),
                            }
                        )
                    elif participant is None:
                        raise InputError(f"{kind} message before join; allowed first: join")
                    elif kind == "consent":
                        store.consent(participant["id"])
                        participant["status"] = "consented"
                        await send({"type": "consented"})
                    elif kind == "start":
                        if participant["status"] == "new":
                            raise InputError("start: please read the consent text and agree first")
                        if session is None:
                            session = registry.start(participant["id"], notify)
                            sender = asyncio.create_task(send_updates(session))
                        notify()
                    elif session is None:
                        raise InputError(f"{kind} message before start; allowed first: start")
                    else:
                        deliver(session, data)
                except InputError as error:
                    await send({"type": "error", "message": str(error)})
        except WebSocketDisconnect:
            pass
        finally:
            if sender is not None:
                sender.cancel()
            if session is not None:
                generation = registry.detach(session)
                loop.call_later(settings.grace_seconds, registry.expire, session, generation)

    return app


class StudyServer(Serving):
    """A study's app served by uvicorn on ``host``:``port``, in this thread (``run``) or another (``start``)."""

    thread_name = "aaai-study-server"

    def __init__(
        self,
        study: Study,
        store: Store,
        settings: PlaySettings,
        host: str = "127.0.0.1",
        port: int = 8000,
        max_sessions: int | None = None,
        public_url: str | None = None,
    ):
        origins = [public_origin(public_url)] if public_url else None
        self.sock = bind(host, port)
        self.port = self.sock.getsockname()[1]
        self.network = not is_loopback(host)
        self.base_url = f"http://{link_host(host) if self.network else '127.0.0.1'}:{self.port}/"
        if origins:
            self.base_url = origins[0] + "/"
        self.serve(create_study_app(study, store, settings, own_hosts(host, self.port), max_sessions, origins))

    @property
    def registry(self) -> StudyRegistry:
        return self.app.state.registry


def link(base_url: str, token: str) -> str:
    """A participant's link: the server's address with their token."""
    return f"{base_url.rstrip('/')}/?p={token}"


__all__ = [
    "public_origin",
    "StudyRegistry",
    "StudyServer",
    "create_study_app",
    "link",
    "parse_study_message",
]
