"""Who may talk to the ``aaai play`` server: its own page, by its own address, with its token.

Every HTTP request and WebSocket passes :class:`Guard` (Starlette ASGI middleware) before the app
sees it. It answers 403 with a one-line reason unless

* the ``Host`` header is one of the server's own addresses with its port (:func:`own_hosts`: the
  loopback names 127.0.0.1, localhost and [::1] on a loopback server), so that a page of another
  site whose name was made to point at this machine (DNS rebinding) gets nothing;
* the ``Origin`` header, when there is one, is ``http://`` and such an address (or one of the
  ``origins`` given, such as a TLS proxy's ``https://`` address); a WebSocket must
  send one (browsers always do), so that a page of another site cannot open the socket and play;
* on a server listening on a network (``--host`` not loopback), the request carries the server's
  random token: ``?token=...`` in the printed link, then a cookie the server sets on the first
  page it serves with it (``aaai_play_<port>``, HttpOnly, SameSite=Strict).
"""

from __future__ import annotations

import ipaddress
import secrets
import socket
from http.cookies import SimpleCookie

from starlette.datastructures import MutableHeaders
from starlette.requests import HTTPConnection
from starlette.responses import PlainTextResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
WILDCARDS = ("0.0.0.0", "::", "")


def is_loopback(host: str) -> bool:
    """Whether a --host value serves this machine only."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def shown(name: str) -> str:
    """A host name as it appears in a URL (an IPv6 address in brackets), lower-cased."""
    name = name.lower().strip("[]")
    return f"[{name}]" if ":" in name else name


def outward_address() -> str | None:
    """The address packets to the outside leave this machine from (found without sending any)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))
            return str(probe.getsockname()[0])
        except OSError:
            return None


def machine_names() -> set[str]:
    """This machine's names and addresses, as another machine may reach it (not the loopback ones)."""
    names = {socket.gethostname(), socket.getfqdn(), outward_address() or ""}
    for name in list(names):
        try:
            names |= {str(info[4][0]) for info in socket.getaddrinfo(name, None)} if name else set()
        except OSError:
            pass
    return {name for name in names if name and not is_loopback(name)}


def own_hosts(host: str, port: int) -> list[str]:
    """The ``Host`` values (name:port) of a server listening on ``host`` and ``port``: the
    loopback names on a loopback server; on a network, the --host value and this machine's names
    and addresses (and the loopback names too when it listens on every address)."""
    names: set[str] = set()
    if is_loopback(host) or host in WILDCARDS:
        names |= set(LOOPBACK_NAMES)
    if not is_loopback(host):
        names |= machine_names()
    if host not in WILDCARDS:
        names.add(host)
    hosts = sorted(f"{shown(name)}:{port}" for name in names)
    return hosts + sorted(shown(name) for name in names) * (port == 80)  # a browser leaves out port 80


def refusal(reason: str) -> PlainTextResponse:
    return PlainTextResponse(f"refused: {reason}\n", status_code=403)


class Guard:
    """ASGI middleware: a request or WebSocket that is not from the server's own page, by its own
    address (and, on a network, with its token) gets 403 and the reason, and never reaches the app."""

    def __init__(
        self,
        app: ASGIApp,
        hosts: list[str],
        token: str | None = None,
        cookie: str = "aaai_play",
        origins: list[str] | None = None,
    ):
        """``origins``: pages at other addresses that may talk to it too, such as the ``https://`` address
        of a TLS proxy in front of it (their hosts are added to ``hosts``, for the proxy's Host header)."""
        self.app, self.token, self.cookie = app, token, cookie
        own, extra = [h.lower() for h in hosts], [o.lower().rstrip("/") for o in origins or []]
        self.hosts = own + [o.split("://", 1)[1] for o in extra]
        self.origins = [f"http://{h}" for h in own] + extra

    def check(self, connection: HTTPConnection, websocket: bool) -> tuple[str | None, bool]:
        """(the reason to refuse, or None; whether the token came in the query, so the cookie is set)."""
        host = connection.headers.get("host", "")
        if host.lower() not in self.hosts:
            return f"Host {host!r} is not this server's; allowed: {', '.join(self.hosts)}", False
        origin = connection.headers.get("origin")
        if origin is None and websocket:
            return "a WebSocket without an Origin header; allowed: one from this server's page", False
        if origin is not None and origin.lower() not in self.origins:
            return f"Origin {origin!r} is not this server's page; allowed: {', '.join(self.origins)}", False
        if self.token is None:
            return None, False
        given = connection.query_params.get("token")
        if given is not None and secrets.compare_digest(given.encode(), self.token.encode()):
            return None, True
        cookie = connection.cookies.get(self.cookie)
        if cookie is not None and secrets.compare_digest(cookie.encode(), self.token.encode()):
            return None, False
        what = "a wrong token" if given is not None else "no token"
        return (
            f"{what}: this server listens on a network and serves only the link `aaai play` printed, "
            f"http://HOST:PORT/?token=..."
        ), False

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        websocket = scope["type"] == "websocket"
        reason, set_cookie = self.check(HTTPConnection(scope), websocket)
        if reason is not None:
            if websocket and "websocket.http.response" not in scope.get("extensions", {}):
                await send({"type": "websocket.close", "code": 1008, "reason": reason[:120]})
            else:
                await refusal(reason)(scope, receive, send)
            return
        if not set_cookie or websocket:
            await self.app(scope, receive, send)
            return

        async def send_with_cookie(message: Message) -> None:
            if message["type"] == "http.response.start":
                cookie: SimpleCookie = SimpleCookie()
                cookie[self.cookie] = self.token or ""
                morsel = cookie[self.cookie]
                morsel["path"], morsel["httponly"], morsel["samesite"] = "/", True, "Strict"
                MutableHeaders(scope=message).append("set-cookie", cookie.output(header="").strip())
            await send(message)

        await self.app(scope, receive, send_with_cookie)


def link_host(host: str) -> str:
    """The host name for the printed link of a server listening on ``host``."""
    if host in WILDCARDS:
        return shown(outward_address() or socket.gethostname())
    return shown(host)


__all__ = ["WILDCARDS", "Guard", "is_loopback", "link_host", "own_hosts", "shown"]
