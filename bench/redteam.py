"""Red-team attacks on the command line, the environment, the files it reads and the play server.

Each attack is a small data case: a command (``aaai ...``, or a few lines of Python for the
environment and the play server) with the files it is given, made in a fresh folder. Every
attack runs in its own process with a time limit and a memory cap, and is classified:

* CLEAN: it exits with a clear error (no Python traceback), or it succeeds as it should, within
  the time and memory limits, leaving nothing outside its folder (a file ``outside/`` holds is
  unchanged) and running no code (a payload would create the canary file ``CANARY``);
* FAIL, with the reason, otherwise.

Results go to ``bench/redteam.csv`` (one row per attack, rewritten atomically after each), so a
killed run resumes where it stopped; ``--rerun`` runs every attack again, ``--only GROUP`` one
group. ``python bench/redteam.py`` prints the counts by group.

The attacks are in ``bench/redteam_attacks/``, a module per group; this script runs and classifies them.
"""

import argparse
import csv
import io
import os
import shlex
import shutil
import signal
import subprocess
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from redteam_attacks import register
from redteam_attacks.base import AAAI, BASE, HERE, PY, Attack, Result, limit, prepare
from redteam_attacks.play import play_server, server_alive

CSV_PATH = HERE / "redteam.csv"
COLUMNS = ["id", "group", "command", "outcome", "reason", "seconds"]


# --- running and classifying ---------------------------------------------------------------
def snapshot(path: Path) -> dict:
    """Each path under ``path``: (a link, its size, its bytes), or None where it cannot be read."""
    out: dict[str, tuple[bool, int, bytes] | None] = {}
    for p in sorted(path.rglob("*")):
        try:
            out[str(p)] = (
                p.is_symlink(),
                p.lstat().st_size,
                p.read_bytes() if p.is_file() and not p.is_symlink() else b"",
            )
        except OSError:
            out[str(p)] = None
    return out


def execute(a: Attack, extra_env: dict | None = None) -> tuple[str, str, float]:
    try:
        return _execute(a, extra_env)
    except Exception as error:  # a fault of this script, not of the command: shown, never counted clean
        return "ERROR", f"the attack itself failed: {type(error).__name__}: {error}"[:200], 0.0


def _execute(a: Attack, extra_env: dict | None = None) -> tuple[str, str, float]:
    top = BASE / a.id
    shutil.rmtree(top, ignore_errors=True)
    w, outside = top / "work", top / "outside"
    for d in (w, outside, top / "home"):
        d.mkdir(parents=True)
    if a.setup:
        a.setup(w)
    before = snapshot(outside)
    argv = [x.replace("{W}", str(w)) for x in a.argv]
    env = {
        **os.environ,
        "HOME": str(top / "home"),
        "MPLBACKEND": "Agg",
        "PYTHONWARNINGS": "ignore",
        "AAAI_CHECKPOINT_KEY": str(top / "home" / "key"),
        **a.env,
        **(extra_env or {}),
    }
    start = time.monotonic()
    proc = subprocess.Popen(
        ["nice", "-n", "10", *argv], cwd=w, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=limit
    )
    try:
        out, err = proc.communicate(timeout=a.timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        code = None
    seconds = time.monotonic() - start
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # anything it left behind
    except ProcessLookupError:
        pass
    r = Result(code, out.decode(errors="replace"), err.decode(errors="replace"), seconds)
    outcome, reason = classify(a, r, w, before, outside, top)
    if outcome == "CLEAN":
        shutil.rmtree(top, ignore_errors=True)
    else:
        (top / "stderr.txt").write_text(r.stderr)
        (top / "stdout.txt").write_text(r.stdout[-100_000:])
    return outcome, reason, seconds


def last_line(s: str) -> str:
    lines = [x for x in s.strip().splitlines() if x.strip()]
    return lines[-1][:200] if lines else ""


def classify(a: Attack, r: Result, w: Path, before, outside, top) -> tuple[str, str]:
    if r.code is None:
        return "FAIL", f"no answer within {a.timeout:g} s"
    if (top / "CANARY").exists():
        return "FAIL", "a payload ran (the canary file exists)"
    if "Traceback (most recent call last)" in r.stderr + r.stdout:
        return "FAIL", "traceback: " + last_line(r.stderr.split("Traceback (most recent call last)")[-1])
    if r.code < 0:
        return "FAIL", f"killed by signal {-r.code}"
    if "MemoryError" in r.stderr or "Segmentation" in r.stderr:
        return "FAIL", last_line(r.stderr)
    if snapshot(outside) != before:
        return "FAIL", "something outside its folder was changed"
    if a.check:
        problem = a.check(w, r)
        if problem:
            return "FAIL", problem
    if r.code != 0:
        line = last_line(r.stderr) or last_line(r.stdout)  # import-animalai says SKIPPED on stdout
        if not line:
            return "FAIL", f"exit {r.code} with no message"
        if a.expect == "ok":
            return "FAIL", f"refused: {line}"
        return "CLEAN", f"refused: {line}"
    if a.expect == "error":
        return "FAIL", "accepted (exit 0); expected a refusal"
    return "CLEAN", "ok" + (f": {last_line(r.stdout)}" if a.group == "play-http" else "")


def read_rows() -> dict[str, dict]:
    if not CSV_PATH.is_file():
        return {}
    try:
        return {row["id"]: row for row in csv.DictReader(CSV_PATH.open(newline=""))}
    except (csv.Error, KeyError):
        return {}


def write_rows(rows: dict[str, dict], attacks: list[Attack]) -> None:
    order = {a.id: i for i, a in enumerate(attacks)}
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in sorted(rows.values(), key=lambda r: order.get(r["id"], 10**6)):
        writer.writerow({k: row.get(k, "") for k in COLUMNS})
    temp = CSV_PATH.with_suffix(".csv.tmp")
    with open(temp, "w", newline="") as f:
        f.write(buffer.getvalue())
        f.flush()
        os.fsync(f.fileno())
    os.replace(temp, CSV_PATH)


def shown_command(a: Attack) -> str:
    argv = ["aaai" if x == AAAI else "python" if x == PY else x for x in a.argv]
    if argv[0] == "python" and len(argv) > 2:
        argv = argv[:2] + [f"<{a.group} script>"] + [x if len(x) < 80 else x[:77] + "..." for x in argv[3:]]
    s = shlex.join(argv)
    return s if len(s) <= 300 else s[:297] + "..."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rerun", action="store_true", help="run every attack again")
    parser.add_argument("--only", help="only this group (or an attack id prefix)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--list", action="store_true")
    args = parser.parse_args()
    BASE.mkdir(parents=True, exist_ok=True)
    prepare()
    attacks = register()
    if args.list:
        for a in attacks:
            print(a.id, a.group, shown_command(a))
        print(len(attacks), "attacks")
        return
    rows = {} if args.rerun and not args.only else read_rows()
    chosen = [a for a in attacks if not args.only or a.group == args.only or a.id.startswith(args.only)]
    todo = [a for a in chosen if args.rerun or a.id not in rows]
    lock = threading.Lock()

    def record(a: Attack, outcome: str, reason: str, seconds: float) -> None:
        with lock:
            rows[a.id] = {
                "id": a.id,
                "group": a.group,
                "command": shown_command(a),
                "outcome": outcome,
                "reason": reason,
                "seconds": f"{seconds:.2f}",
            }
            write_rows(rows, attacks)
            print(f"{outcome:5} {seconds:6.1f}s {a.id}: {reason}"[:220], flush=True)

    plain = [a for a in todo if a.group != "play-http"]
    with ThreadPoolExecutor(args.jobs) as pool:
        for a, (outcome, reason, seconds) in zip(plain, pool.map(execute, plain)):
            record(a, outcome, reason, seconds)
    web = [a for a in todo if a.group == "play-http"]
    if web:
        proc, port, err = play_server(BASE / "_play")
        try:
            for a in web:
                seen = err.stat().st_size
                outcome, reason, seconds = execute(a, {"PORT": str(port)})
                new = err.read_bytes()[seen:].decode(errors="replace")
                if outcome == "CLEAN" and "Traceback" in new:
                    outcome, reason = "FAIL", "server traceback: " + last_line(new)
                if outcome == "CLEAN" and not server_alive(port):
                    outcome, reason = "FAIL", "the server stopped answering its page"
                record(a, outcome, reason, seconds)
        finally:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
    groups: dict[str, list[int]] = {}
    for row in rows.values():
        counts = groups.setdefault(row["group"], [0, 0])
        counts[0] += 1
        counts[1] += row["outcome"] == "CLEAN"
    total, clean = sum(c[0] for c in groups.values()), sum(c[1] for c in groups.values())
    for group, (n, c) in sorted(groups.items()):
        print(f"{group:16} {c:4} / {n:4} clean")
    print(f"{'all':16} {clean:4} / {total:4} clean ({100 * clean / max(total, 1):.1f} %)")
    for row in rows.values():
        if row["outcome"] != "CLEAN":
            print(f"FAIL {row['id']}: {row['reason']}")


if __name__ == "__main__":
    main()
