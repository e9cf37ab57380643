"""How many participants one core holds at 50 Hz: N sessions at once against `aaai study serve`.

For each N, a fresh study (one battery trial of --seconds, the camera at --resolution) gets N
participant links; `aaai study serve` runs in its own process; N WebSocket pages (aaai.study.loadtest)
play the trial at once, holding a key and acknowledging every frame, as the participant page does.
Measured per N: each page's control steps per second (wall clock), whether every finished trial's
row is in the store, and the CPU time the server process used (from /proc) per session per second
of play. Sessions per core = 1 / that CPU cost, with 10% headroom (the figure behind
aaai.tools.play.server.SESSIONS_PER_CORE, the cap of aaai play and aaai study serve, which is
set below it for slower machines than the bench's). The load average is recorded with each row: the machine
may be shared.

    .venv/bin/python bench/study_load.py                  # N = 1 2 4 6 8, 84 px, 5 s trials
    .venv/bin/python bench/study_load.py --sessions 1 3 --seconds 3

Resumable: a row already in bench/study_load.csv for (N, resolution, seconds) is not measured
again (--again measures it again). Writes bench/study_load.csv and bench/study_load.md.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from aaai.files import write_atomic  # noqa: E402
from aaai.study.loadtest import cpu_seconds, play_together  # noqa: E402
from aaai.study.store import Store  # noqa: E402
from aaai.study.studyfile import load_study  # noqa: E402

CSV = ROOT / "bench" / "study_load.csv"
MD = ROOT / "bench" / "study_load.md"
COLUMNS = [
    "sessions",
    "resolution",
    "seconds",
    "min_steps_per_s",
    "mean_steps_per_s",
    "rows_landed",
    "server_cpu_s",
    "cpu_per_session_s",
    "sessions_per_core",
    "load_average",
    "when",
]
HEADROOM = 0.9  # a core is counted at 90%: the server's event loop, sockets and frames need the rest


def study_text(seconds: float, resolution: int) -> str:
    return (
        "name: load\nbattery:\n  - {level: 0, difficulty: 0, seed: 1}\norder: fixed\n"
        f"time_limit: {seconds}\ncamera_resolution: {resolution}\n"
    )


def serve(study: Path, max_sessions: int) -> tuple[subprocess.Popen, int]:
    command = [sys.executable, "-m", "aaai_cli.main", "study", "serve", str(study), "--port", "0", "--grace", "0"]
    process = subprocess.Popen(
        [*command, "--max-sessions", str(max_sessions)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    assert process.stdout is not None
    line = process.stdout.readline()
    if "http://127.0.0.1:" not in line:
        process.kill()
        raise SystemExit(f"study_load: the server did not start: {line}")
    return process, int(line.split("http://127.0.0.1:")[1].split("/")[0])


def measure(n: int, seconds: float, resolution: int) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        study = Path(folder) / "load.yaml"
        study.write_text(study_text(seconds, resolution))
        made = subprocess.run(
            [sys.executable, "-m", "aaai_cli.main", "study", "participants", str(study), "-n", str(n)],
            capture_output=True,
            text=True,
        )
        if made.returncode:
            raise SystemExit(made.stdout + made.stderr)
        with open(Path(folder) / "load_links.csv") as handle:
            tokens = [row["link"].split("?p=")[1] for row in csv.DictReader(handle)]
        process, port = serve(study, n)
        try:
            time.sleep(1.0)  # the server's start-up is not play
            before, start = cpu_seconds(process.pid), time.monotonic()
            results = play_together(port, tokens, timeout=seconds + 60)
            cpu, wall = cpu_seconds(process.pid) - before, time.monotonic() - start
            load = os.getloadavg()[0]
        finally:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(15)
            except subprocess.TimeoutExpired:
                process.kill()
        store = Store(load_study(study).store, "load", writer=False)
        try:
            rows = sum(
                bool(t["finished"]) and json.loads(t["row"])["steps"] == round(seconds / 0.02)
                for p in store.participants()
                for t in store.trials(p["id"])
            )
        finally:
            store.close()
    refused = [r.refused for r in results if r.refused]
    if refused:
        raise SystemExit(f"study_load: a page was refused: {refused[0]}")
    played = n * seconds
    per_session = cpu / played
    return {
        "sessions": n,
        "resolution": resolution,
        "seconds": seconds,
        "min_steps_per_s": round(min(r.rate for r in results), 1),
        "mean_steps_per_s": round(sum(r.rate for r in results) / n, 1),
        "rows_landed": f"{rows}/{n}",
        "server_cpu_s": round(cpu, 2),
        "cpu_per_session_s": round(per_session, 3),
        "sessions_per_core": round(HEADROOM / per_session, 1),
        "load_average": round(load, 2),
        "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()) + f" (wall {wall:.1f} s)",
    }


def read_rows() -> list[dict]:
    if not CSV.exists():
        return []
    with open(CSV) as handle:
        return list(csv.DictReader(handle))


def write(rows: list[dict]) -> None:
    lines = [",".join(COLUMNS)] + [",".join(str(row[c]) for c in COLUMNS) for row in rows]
    write_atomic(CSV, "\n".join(lines) + "\n")
    table = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    table += ["| " + " | ".join(str(row[c]) for c in COLUMNS) + " |" for row in rows]
    text = (
        "# Participants at once (bench/study_load.py)\n\n"
        "N participants play one trial at once over WebSockets against `aaai study serve` on loopback, "
        "each stepping its own world at 50 Hz in real time. `min/mean_steps_per_s`: the control steps "
        "per second each page saw (wall clock); `rows_landed`: finished trials whose row is in the store; "
        "`cpu_per_session_s`: the server process's CPU seconds per session per second of play; "
        f"`sessions_per_core`: {HEADROOM} / that. `load_average`: the machine's 1-minute load "
        "at the end of the row (the machine is shared).\n\n" + "\n".join(table) + "\n"
    )
    write_atomic(MD, text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, nargs="+", default=[1, 2, 4, 6, 8])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--resolution", type=int, default=84)
    parser.add_argument("--again", action="store_true", help="Measure rows already in the CSV again.")
    args = parser.parse_args()
    rows = read_rows()
    for n in args.sessions:
        key = (str(n), str(args.resolution), str(args.seconds))
        if not args.again and any((r["sessions"], r["resolution"], r["seconds"]) == key for r in rows):
            continue
        row = measure(n, args.seconds, args.resolution)
        print(json.dumps(row), flush=True)
        rows = [r for r in rows if (r["sessions"], r["resolution"], r["seconds"]) != key] + [row]
        rows.sort(key=lambda r: (int(r["resolution"]), float(r["seconds"]), int(r["sessions"])))
        write(rows)


if __name__ == "__main__":
    main()
