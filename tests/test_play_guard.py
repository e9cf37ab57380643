"""aaai play against other web pages and abuse: Origin, Host (DNS rebinding) and the network token
are checked before anything is served; joins are capped and a left session is freed; player names
are the only way into a file name; any WebSocket message gets a clean refusal, never a crash."""

from __future__ import annotations

import http.client
import json
import os
import socket
import time
from contextlib import ExitStack

import pytest
from click.testing import CliRunner

from aaai_cli.main import cli

if not os.environ.get("CI"):  # on CI (make test installs the play extra) a missing library fails, never skips
    pytest.importorskip("fastapi", reason="aaai play needs the play extra (make test installs it)")
import pybullet as p  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from test_play import Page, settings_for, startable  # noqa: E402
from websockets.exceptions import ConnectionClosed, InvalidStatus  # noqa: E402
from websockets.sync.client import connect  # noqa: E402

from aaai.tools.play.server import MESSAGE_TYPES, Server  # noqa: E402
from aaai.tools.play.session import KEYS, InputError, PlaySettings, check_player  # noqa: E402

FUZZ = settings(max_examples=100, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))


def get(server: Server, path: str = "/", host: str | None = None, **headers: str) -> tuple[int, str, dict]:
    """An HTTP GET to the server on loopback with the Host (and other headers) given."""
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=5)
    try:
        connection.request("GET", path, headers={"Host": host or f"127.0.0.1:{server.port}", **headers})
        response = connection.getresponse()
        return response.status, response.read().decode(), {k.lower(): v for k, v in response.getheaders()}
    finally:
        connection.close()


def open_socket(server: Server, host: str | None = None, origin: str | None = None, query: str = "", **headers):
    """A WebSocket to the server on loopback, as if the page had been loaded from ``host``."""
    sock = socket.create_connection(("127.0.0.1", server.port), timeout=5)
    uri = f"ws://{host or f'127.0.0.1:{server.port}'}/ws{query}"
    try:
        return connect(uri, sock=sock, origin=origin, additional_headers=headers or None, open_timeout=5)
    except BaseException:
        sock.close()
        raise


def refused(server: Server, **how) -> str:
    """The 403 body of a WebSocket that is refused (fails if it is accepted)."""
    with pytest.raises(InvalidStatus) as caught:
        open_socket(server, **how).close()
    assert caught.value.response.status_code == 403
    return caught.value.response.body.decode()


def hello_of(server: Server, **how) -> dict:
    with open_socket(server, **how) as ws:
        return json.loads(ws.recv(5))


def connections() -> int:
    """PyBullet clients connected in this process."""
    return sum(p.isConnected(client) for client in range(64))


@pytest.fixture(scope="module")
def loopback(tmp_path_factory):
    """A loopback server whose only player is "fuzz" (other names are refused before any session)."""
    server = Server(settings_for(tmp_path_factory.mktemp("play"), player="fuzz", grace_seconds=60.0), port=0)
    yield server.start()
    server.stop()


def test_a_websocket_from_another_origin_or_none_is_refused_and_the_page_s_own_is_served(loopback):
    own = f"http://127.0.0.1:{loopback.port}"
    body = refused(loopback, origin="http://evil.example")
    assert "Origin 'http://evil.example' is not this server's page" in body and own in body
    assert "without an Origin" in refused(loopback)  # not a browser's page: no Origin at all
    assert "is not this server's page" in refused(loopback, origin=f"http://127.0.0.1:{loopback.port + 1}")
    assert "is not this server's page" in refused(loopback, origin="null")  # a sandboxed frame, a file
    assert hello_of(loopback, origin=own)["type"] == "hello"
    localhost = f"localhost:{loopback.port}"
    assert hello_of(loopback, host=localhost, origin=f"http://{localhost}")["type"] == "hello"
    status, body, _ = get(loopback, "/api/sessions", Origin="http://evil.example")  # a script of another site
    assert status == 403 and "Origin 'http://evil.example'" in body
    assert loopback.registry.all() == []


def test_a_request_by_another_host_name_is_refused_dns_rebinding(loopback):
    rebound = f"rebind.evil.example:{loopback.port}"
    for path in ("/", "/api/sessions", "/static/play.js"):
        status, body, _ = get(loopback, path, host=rebound)
        assert status == 403 and body.startswith(f"refused: Host '{rebound}' is not this server's"), (path, body)
        assert f"127.0.0.1:{loopback.port}" in body and "player" not in body
    body = refused(loopback, host=rebound, origin=f"http://{rebound}")
    assert f"Host '{rebound}'" in body
    assert get(loopback, host=f"127.0.0.1:{loopback.port + 1}")[0] == 403  # another port is another server
    for host in (f"127.0.0.1:{loopback.port}", f"localhost:{loopback.port}", f"[::1]:{loopback.port}"):
        status, body, headers = get(loopback, "/api/sessions", host=host)
        assert status == 200 and json.loads(body) == [] and "set-cookie" not in headers, host
    status, body, _ = get(loopback, "/")
    assert status == 200 and "aaai play" in body


def test_a_network_server_serves_only_its_link_s_token(tmp_path, monkeypatch):
    server = Server(settings_for(tmp_path), host="0.0.0.0", port=0).start()
    try:
        token = server.token
        assert token and len(token) >= 32 and server.url.endswith(f":{server.port}/?token={token}")
        assert server.local_url == f"http://127.0.0.1:{server.port}/?token={token}"
        origin = f"http://127.0.0.1:{server.port}"
        for path in ("/", "/api/sessions", "/static/play.js", "/?token=" + "x" * len(token)):
            status, body, _ = get(server, path)
            assert status == 403 and "token: this server listens on a network" in body, (path, body)
        assert "no token" in refused(server, origin=origin)
        assert "a wrong token" in refused(server, origin=origin, query="?token=nope")
        status, body, headers = get(server, f"/?token={token}")  # the printed link: the page, and a cookie
        assert status == 200 and "aaai play" in body
        cookie = headers["set-cookie"].split(";")[0]
        assert cookie == f"aaai_play_{server.port}={token}" and "HttpOnly" in headers["set-cookie"]
        assert "SameSite=Strict" in headers["set-cookie"]
        assert get(server, "/static/play.js", Cookie=cookie)[0] == 200  # the page's script, by its cookie
        assert get(server, "/api/sessions", Cookie=cookie)[0] == 200
        assert hello_of(server, origin=origin, query=f"?token={token}")["type"] == "hello"
        assert hello_of(server, origin=origin, Cookie=cookie)["type"] == "hello"
        assert "Origin 'http://evil.example'" in refused(server, origin="http://evil.example", query=f"?token={token}")
        assert get(server, f"/?token={token}", host=f"rebind.evil.example:{server.port}")[0] == 403
    finally:
        server.stop()
    # what `aaai play --host 0.0.0.0` prints: the link with its token
    monkeypatch.setattr(Server, "run", lambda self: self.sock.close())
    result = CliRunner().invoke(
        cli, ["play", "--host", "0.0.0.0", "--port", "0", "--out", str(tmp_path / "h_{player}.csv")]
    )
    assert result.exit_code == 0, result.output
    assert "/?token=" in result.output and "the token in it is the only key" in result.output
    result = CliRunner().invoke(cli, ["play", "--port", "0", "--out", str(tmp_path / "h_{player}.csv")])
    assert result.exit_code == 0 and "token" not in result.output and "http://127.0.0.1:" in result.output


def test_joins_beyond_max_sessions_are_refused_and_a_left_session_is_freed(tmp_path):
    before = connections()
    server = Server(settings_for(tmp_path, max_steps=1000, max_sessions=2), port=0).start()
    registry = server.registry
    try:
        with ExitStack() as stack:
            bob, cy = Page(stack, server), Page(stack, server)
            with ExitStack() as ann_tab:
                ann = Page(ann_tab, server)
                ann.join("ann")
                bob.join("bob")
                ann.pump(startable)
                bob.pump(startable)
                cy.join("cy")
                reply = json.loads(cy.ws.recv(5))
                assert reply["type"] == "error", reply
                assert reply["message"] == (
                    "the server is full: 2 players are playing (--max-sessions 2); try again when one has finished"
                )
                assert connections() == before + 2 and len(registry.all()) == 2
            # ann's tab is closed: with no grace period her session is abandoned and freed
            deadline = time.monotonic() + 5
            while len(registry.all()) > 1 or connections() > before + 1:
                assert time.monotonic() < deadline, (registry.all(), connections())
                time.sleep(0.02)
            assert [s.player for s in registry.all()] == ["bob"]
            cy.join("cy")  # there is room again
            cy.pump(startable)
            assert connections() == before + 2
        deadline = time.monotonic() + 5
        while registry.all() or connections() > before:  # every tab gone: every session freed
            assert time.monotonic() < deadline, (registry.all(), connections())
            time.sleep(0.02)
    finally:
        server.stop()
    assert connections() == before


@pytest.mark.parametrize(
    "name", ["..", ".", "../up", "a/b", "a\\b", "", " ", "a.b", "a b", "é", "a\n", "a" * 41, None, 7, ["a"]]
)
def test_a_player_name_that_is_not_a_plain_word_is_refused(name):
    with pytest.raises(InputError, match=r"player: got .*; allowed: 1 to 40 letters \(A-Z, a-z\), digits, '-' or '_'"):
        check_player(name)
    with pytest.raises(InputError):
        PlaySettings(config={}, output="out/{player}/scores.csv").output_for(name)


def test_player_names_reach_file_names_only_plain(tmp_path, loopback):
    assert check_player("Ann_2-b") == "Ann_2-b" and check_player("a" * 40) == "a" * 40
    settings = PlaySettings(config={}, output=str(tmp_path / "{player}" / "h_{player}.csv"))
    assert settings.output_for("ann") == tmp_path / "ann" / "h_ann.csv"
    with ExitStack() as stack:  # the page is told, and nothing is written
        page = Page(stack, loopback)
        page.join("..")
        reply = json.loads(page.ws.recv(5))
        assert reply["type"] == "error" and reply["message"].startswith("player: got '..'; allowed: 1 to 40")
    result = CliRunner().invoke(cli, ["play", "--player", "..", "--out", str(tmp_path / "{player}.csv")])
    assert result.exit_code == 2 and "player: got '..'" in result.output
    assert list(tmp_path.iterdir()) == [] and loopback.registry.all() == []


# --- fuzzing the socket's messages ------------------------------------------------------------
json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)
typed = st.fixed_dictionaries(
    {"type": st.sampled_from(MESSAGE_TYPES) | st.text(max_size=6)},
    optional={
        "player": json_values | st.sampled_from(["ann", "..", "a/b", "fuzz"]),
        "token": json_values,
        "key": json_values | st.sampled_from(KEYS),
        "down": json_values,
        "focused": json_values,
        "frame": json_values | st.integers(-(2**70), 2**70),
    },
)
well_formed = st.one_of(  # a known type with its flag right, the rest anything
    st.fixed_dictionaries({"type": st.just("key"), "key": json_values | st.sampled_from(KEYS), "down": st.booleans()}),
    st.fixed_dictionaries({"type": st.just("focus"), "focused": st.booleans()}),
    st.fixed_dictionaries({"type": st.just("ack"), "frame": st.integers(-(2**70), 2**70)}),
    st.fixed_dictionaries({"type": st.just("join"), "player": json_values, "token": st.none() | st.text(max_size=30)}),
)
messages = st.one_of(
    well_formed.map(json.dumps),
    typed.map(json.dumps),
    json_values.map(json.dumps),
    st.text(max_size=40),
    st.binary(max_size=40),
    st.text(min_size=990, max_size=1100, alphabet='{}[]":,x1 '),  # about the size limit
)
REPLIES = {"hello", "joined", "status", "frame", "error"}
SENTINEL = "end of example"


def exchange(ws, sent: list) -> list[dict]:
    """Sends the messages, then one the server answers with a known error, and returns what came
    back before that error: every message must have an answer or be ignored, none may crash."""
    for message in sent:
        ws.send(message)
    ws.send(SENTINEL)
    replies = []
    while True:
        reply = ws.recv(10)
        if isinstance(reply, bytes):
            continue  # a frame's images
        data = json.loads(reply)
        assert data["type"] in REPLIES, data
        if data["type"] == "error" and repr(SENTINEL) in data["message"]:
            return replies
        replies.append(data)


@pytest.fixture(scope="module")
def joined(loopback):
    with ExitStack() as stack:
        page = Page(stack, loopback)
        page.join("fuzz")
        page.pump(lambda status: page.joined is not None)
        yield page


@pytest.fixture(scope="module")
def unjoined(loopback):
    """A page that has not joined (and cannot: the server plays only "fuzz", which it never sends)."""
    with open_socket(loopback, origin=f"http://127.0.0.1:{loopback.port}") as ws:
        assert json.loads(ws.recv(5))["type"] == "hello"
        yield ws


@FUZZ
@given(st.lists(messages, min_size=1, max_size=4))
def test_any_message_before_join_is_refused_cleanly(unjoined, sent):
    replies = exchange(unjoined, [m for m in sent if not (isinstance(m, str) and '"fuzz"' in m)])
    assert all(r["type"] == "error" and r["message"] for r in replies), replies


@FUZZ
@given(st.lists(messages, min_size=1, max_size=4))
def test_any_message_to_a_joined_session_is_taken_or_refused_cleanly(joined, sent):
    replies = exchange(joined.ws, sent)
    errors = [r for r in replies if r["type"] == "error"]
    assert all(r["message"] and len(r["message"]) < 1500 for r in errors), errors


def test_huge_and_binary_messages_are_refused_and_the_server_serves_on(loopback, joined):
    with open_socket(loopback, origin=f"http://127.0.0.1:{loopback.port}") as ws:
        ws.recv(5)
        [reply] = exchange(ws, ["x" * 5000])
        assert reply["message"] == "message: got 5000 characters; allowed: at most 1000"
        [reply] = exchange(ws, [b"\x00" * 100])
        assert reply["message"] == "message: got a binary message; allowed: JSON text"
        ws.send("x" * (2 << 20))  # beyond the socket's frame limit: the connection is closed (1009)
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                ws.recv(5)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009
    assert hello_of(loopback, origin=f"http://127.0.0.1:{loopback.port}")["type"] == "hello"
    assert get(loopback, "/api/sessions")[0] == 200
    assert exchange(joined.ws, ['{"type": "focus", "focused": true}']) is not None  # the joined page plays on
