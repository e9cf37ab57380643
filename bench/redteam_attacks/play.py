"""The play-http group and its server: raw HTTP requests (methods, paths, headers) and WebSocket
messages sent to one ``aaai play`` on 127.0.0.1, and that server started and asked if it is alive."""

from __future__ import annotations

import json
import socket
import subprocess
import threading
from pathlib import Path

from .base import AAAI, PY, attack, limit
from .inputs import text

GROUP = "play-http"

HTTP_CLIENT = r"""
import socket, sys, os
port = int(os.environ["PORT"])
request = open(sys.argv[1], "rb").read().replace(b"PORT", str(port).encode())
s = socket.create_connection(("127.0.0.1", port), timeout=10)
try:
    s.sendall(request)
    if os.environ.get("HALF"):
        s.shutdown(socket.SHUT_WR)
    data = b""
    while len(data) < 2_000_000:
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
        if b"\r\n\r\n" in data and not os.environ.get("READ_ALL"):
            head, _, body = data.partition(b"\r\n\r\n")
            length = [l for l in head.split(b"\r\n") if l.lower().startswith(b"content-length:")]
            if not length or len(body) >= int(length[0].split(b":")[1]):
                break
except socket.timeout:
    pass
status = data.split(b"\r\n", 1)[0].decode(errors="replace")
print(status)
if b"root:" in data or b"def create_app" in data:
    print("Error: the answer holds a file of this machine", file=sys.stderr); sys.exit(3)
code = int(status.split()[1]) if status.startswith("HTTP/") else 0
if code >= 500:
    print(f"Error: server error {status}", file=sys.stderr); sys.exit(4)
"""

WS_CLIENT = r"""
import json, os, sys, asyncio
from websockets.asyncio.client import connect
port = int(os.environ["PORT"])
script = json.loads(sys.argv[1])

async def main():
    async with connect(f"ws://127.0.0.1:{port}/ws", origin=f"http://127.0.0.1:{port}", max_size=None,
                       open_timeout=10) as ws:
        await asyncio.wait_for(ws.recv(), 10)  # hello
        for message in script:
            await ws.send(message if isinstance(message, str) else bytes.fromhex(message["hex"]))
        await ws.send(json.dumps({"type": "focus", "focused": True}))
        try:
            while True:
                answer = await asyncio.wait_for(ws.recv(), 5)
                if isinstance(answer, str) and '"error"' in answer:
                    break
        except asyncio.TimeoutError:
            pass
        except Exception as error:
            print(f"closed: {error}"[:200])

asyncio.run(main())
"""


def attacks():

    def http(name, request: bytes, **env):
        attack(
            f"play-{name}",
            GROUP,
            [PY, "-c", HTTP_CLIENT, "request.bin"],
            text("request.bin", request),
            "any",
            timeout=30,
            **env,
        )

    H = b"Host: 127.0.0.1:PORT\r\n"
    for method in (b"POST", b"PUT", b"DELETE", b"TRACE", b"OPTIONS", b"PATCH", b"FOO", b"get"):
        http(f"method-{method.decode().lower()}", method + b" / HTTP/1.1\r\n" + H + b"Content-Length: 0\r\n\r\n")
    http("connect", b"CONNECT 127.0.0.1:22 HTTP/1.1\r\n" + H + b"\r\n")
    paths = {
        "static-dotdot": b"/static/../../../../etc/passwd",
        "static-encoded-dotdot": b"/static/%2e%2e/%2e%2e/%2e%2e/etc/passwd",
        "static-encoded-slash": b"/static/..%2f..%2fserver.py",
        "static-double-encoded": b"/static/%252e%252e/server.py",
        "static-backslash": b"/static/..\\..\\server.py",
        "double-slash": b"//etc/passwd",
        "static-nul": b"/static/index.html%00.png",
        "raw-nul": b"/\x00",
        "static-dir": b"/static/",
        "static-dotdot-end": b"/static/..",
        "ws-plain-get": b"/ws",
        "long-path": b"/" + b"a" * 100_000,
        "unicode-path": "/static/ü\u202e.js".encode(),
        "overlong-utf8": b"/static/%c0%ae%c0%ae/server.py",
        "absolute-uri": b"http://evil.example/etc/passwd",
        "asterisk": b"*",
        "query-1mb": b"/api/sessions?x=" + b"a" * 1_000_000,
        "static-server-py": b"/static/../server.py",
    }
    for name, path in paths.items():
        http(f"path-{name}", b"GET " + path + b" HTTP/1.1\r\n" + H + b"\r\n")
    headers = {
        "host-unicode": b"GET / HTTP/1.1\r\nHost: 127.0.0.1\xc3\xbc:PORT\r\n\r\n",
        "host-duplicate": b"GET /api/sessions HTTP/1.1\r\nHost: evil.example\r\n" + H + b"\r\n",
        "host-duplicate-good-first": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Host: evil.example\r\n\r\n",
        "host-missing-http10": b"GET /api/sessions HTTP/1.0\r\n\r\n",
        "origin-suffix": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: http://127.0.0.1:PORT.evil.example\r\n\r\n",
        "origin-upper": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: HTTP://127.0.0.1:PORT\r\n\r\n",
        "origin-userinfo": b"GET /api/sessions HTTP/1.1\r\n" + H + b"Origin: http://evil@127.0.0.1:PORT\r\n\r\n",
        "many-headers": b"GET / HTTP/1.1\r\n" + H + b"".join(b"X-%d: v\r\n" % i for i in range(500)) + b"\r\n",
        "header-100kb": b"GET / HTTP/1.1\r\n" + H + b"X-Big: " + b"v" * 100_000 + b"\r\n\r\n",
        "chunked-smuggle": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: 6\r\nTransfer-Encoding: chunked\r\n\r\n"
        b"0\r\n\r\nGET /api/sessions HTTP/1.1\r\nHost: evil.example\r\n\r\n",
        "content-length-huge": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: 99999999999\r\n\r\nabc",
        "content-length-negative": b"POST / HTTP/1.1\r\n" + H + b"Content-Length: -5\r\n\r\n",
        "http09": b"GET /\r\n\r\n",
        "http2-preface": b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n",
        "garbage": bytes(range(256)),
        "empty": b"",
        "bad-cookie": b"GET / HTTP/1.1\r\n" + H + b'Cookie: aaai_play=\xff\xfe; ===; "\r\n\r\n',
        "token-query-surrogate": b"GET /?token=%ED%A0%80 HTTP/1.1\r\n" + H + b"\r\n",
        "ws-upgrade-no-origin": b"GET /ws HTTP/1.1\r\n" + H + b"Upgrade: websocket\r\nConnection: Upgrade\r\n"
        b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
        "ws-upgrade-bad-version": b"GET /ws HTTP/1.1\r\n"
        + H
        + b"Origin: http://127.0.0.1:PORT\r\nUpgrade: websocket\r\n"
        b"Connection: Upgrade\r\nSec-WebSocket-Key: x\r\nSec-WebSocket-Version: 99\r\n\r\n",
        "pipelined-100": (b"GET /api/sessions HTTP/1.1\r\n" + H + b"\r\n") * 100,
    }
    for name, request in headers.items():
        http(f"header-{name}", request, **({"HALF": "1"} if name in ("empty", "http09", "garbage") else {}))

    def ws(name, messages):
        attack(f"play-ws-{name}", GROUP, [PY, "-c", WS_CLIENT, json.dumps(messages)], None, "any", timeout=30)

    join = json.dumps({"type": "join", "player": "tester"})
    ws("join-unicode-player", [json.dumps({"type": "join", "player": "тест\u202e"})])
    ws("join-player-number", [json.dumps({"type": "join", "player": 10**400 if False else 1e308})])
    ws("join-token-object", [json.dumps({"type": "join", "player": "a", "token": {"x": [1]}})])
    ws("join-twice", [join, join])
    ws("key-flood", [join] + [json.dumps({"type": "key", "key": "ArrowUp", "down": i % 2 == 0}) for i in range(500)])
    ws("ack-huge-frame", [join, json.dumps({"type": "ack", "frame": 10**300})])
    ws("ack-negative-frame", [join, json.dumps({"type": "ack", "frame": -1})])
    ws("focus-string", [join, json.dumps({"type": "focus", "focused": "yes"})])
    ws("type-unicode", [json.dumps({"type": "jöin"})])
    ws("nan-json", ['{"type": "key", "key": "ArrowUp", "down": NaN}'])
    ws("duplicate-keys", ['{"type": "join", "type": "key", "player": "a"}'])
    ws("binary-invalid-utf8", [{"hex": "ff" * 100}])
    ws("deep-json", ["[" * 900 + "]" * 900])


def play_server(w: Path):
    """Starts one aaai play on a free loopback port; returns (process, port, stderr path)."""
    w.mkdir(parents=True, exist_ok=True)
    err = open(w / "server.err", "wb")
    proc = subprocess.Popen(
        [
            "nice",
            "-n",
            "10",
            AAAI,
            "play",
            "--port",
            "0",
            "--host",
            "127.0.0.1",
            "--out",
            str(w / "play_{player}.csv"),
            "--max-sessions",
            "4",
            "--grace",
            "0.5",
        ],
        stdout=subprocess.PIPE,
        stderr=err,
        cwd=w,
        preexec_fn=limit,
        text=True,
    )
    assert proc.stdout is not None  # stdout=PIPE
    line = proc.stdout.readline()
    port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
    threading.Thread(target=proc.stdout.read, daemon=True).start()
    return proc, port, w / "server.err"


def server_alive(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n".encode())
            return s.recv(100).startswith(b"HTTP/1.1 200")
    except OSError:
        return False
