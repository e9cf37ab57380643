"""A study's store on a PostgreSQL server (`store: postgresql+psycopg://...`), for a study served
from several machines: a throw-away server is started for these tests (make test-long)."""

from __future__ import annotations

import csv
import glob
import os
import shutil
import socket
import subprocess
import tempfile
import threading
import time
from contextlib import ExitStack
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.study.store import Store
from aaai.study.studyfile import load_study
from aaai_cli.main import cli

pytestmark = pytest.mark.long

STUDY = """\
name: shared
practice:
  - {{level: 0, difficulty: 0, seed: 7}}
battery:
  - {{level: 0, difficulty: 0, seed: 1}}
order: random
time_limit: 0.4
camera_resolution: 16
store: {url}
"""


def postgres_programs() -> tuple[str, str] | None:
    """initdb and postgres: on the PATH, or Debian's /usr/lib/postgresql/N/bin."""
    for folder in [None, *sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True)]:
        initdb, postgres = shutil.which("initdb", path=folder), shutil.which("postgres", path=folder)
        if initdb and postgres:
            return initdb, postgres
    return None


@pytest.fixture(scope="module")
def server_url():
    """A throw-away PostgreSQL server on loopback (trust authentication, user aaai); its base URL."""
    programs = postgres_programs()
    if programs is None:
        pytest.skip("needs PostgreSQL's initdb and postgres programs (apt-get install postgresql)")
    psycopg = pytest.importorskip("psycopg", reason="the PostgreSQL store needs psycopg (the play extra)")
    initdb, postgres = programs
    folder = Path(tempfile.mkdtemp(prefix="aaai-postgres-"))
    user = None
    if os.geteuid() == 0:  # PostgreSQL refuses to run as root: as its own user
        import pwd

        try:
            account = pwd.getpwnam("postgres")
        except KeyError:
            shutil.rmtree(folder)
            pytest.skip("as root, the server runs as the user postgres, and there is none here")
        os.chown(folder, account.pw_uid, account.pw_gid)
        user = "postgres"
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    data = folder / "data"
    setup = [initdb, "-D", str(data), "-U", "aaai", "--auth=trust", "-E", "UTF8"]
    subprocess.run(setup, user=user, check=True, capture_output=True)
    command = [postgres, "-D", str(data), "-k", str(folder), "-p", str(port), "-c", "listen_addresses=127.0.0.1"]
    process = subprocess.Popen(command, user=user, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 30
        while True:
            try:
                with psycopg.connect(f"host=127.0.0.1 port={port} user=aaai dbname=postgres", autocommit=True) as db:
                    db.execute("CREATE DATABASE study")
                break
            except psycopg.OperationalError:
                assert time.monotonic() < end and process.poll() is None, "the PostgreSQL server did not start"
                time.sleep(0.2)
        yield f"postgresql+psycopg://aaai@127.0.0.1:{port}/study"
    finally:
        process.terminate()
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(10)
        shutil.rmtree(folder, ignore_errors=True)


def test_a_study_on_a_postgresql_server_is_served_by_two_machines_exported_and_reported(server_url, tmp_path):
    from test_study import Client, ready

    from aaai.study.participant import play_settings
    from aaai.study.server import StudyServer

    path = tmp_path / "study.yaml"
    path.write_text(STUDY.format(url=server_url))
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "2", "--out", str(tmp_path / "a.csv")])
    assert result.exit_code == 0, result.output
    study = load_study(path)
    # Two servers (two machines) on the one store, both writing: their writes follow one another.
    first, second = Store(study.store, study.name, serving=True), Store(study.store, study.name, serving=True)
    try:
        assert first.journal_mode() == "server"
        added: list[list[dict]] = []
        adders = [
            threading.Thread(target=lambda store=store: added.append(store.add_participants(study, 5)))
            for store in (first, second)
        ]
        for adder in adders:
            adder.start()
        for adder in adders:
            adder.join(30)
        numbers = [row["number"] for row in first.participants()]
        assert numbers == list(range(1, 13)) and sorted(p["id"] for batch in added for p in batch)[0] == "P003"
        token = first.participants()[0]["token"]
        server = StudyServer(study, first, play_settings(study, grace_seconds=0), port=0).start()
        try:
            with ExitStack() as stack:  # P001 plays the practice and the battery trial through
                page = Client(stack, server.port, token)
                page.send({"type": "consent"})
                page.next("consented")
                page.send({"type": "start"})
                page.pump(ready)
                page.send({"type": "key", "key": " ", "down": True})
                page.pump(lambda s: s["phase"] == "ready" and s["kind"] == "battery")
                time.sleep(1.05)
                page.send({"type": "key", "key": "ArrowUp", "down": True})
                page.pump(lambda s: s["phase"] == "finished")
        finally:
            server.stop()
        # P002's attempt was left playing by a server that died; beginning the trial again interrupts it
        dead = second.begin_attempt("P002", 1)
        second.save_attempt("P002", 1, dead, {"steps": 25, "seconds": 0.5, "path_m": 0.4})
        assert second.begin_attempt("P002", 1) == dead + 1
    finally:
        first.close()
        second.close()
    reader = Store(study.store, study.name, writer=False)
    try:
        states = [(a["participant"], a["position"], a["attempt"], a["state"]) for a in reader.attempts()]
        assert states == [
            ("P001", 1, 1, "finished"),
            ("P001", 2, 1, "finished"),
            ("P002", 1, 1, "interrupted"),
            ("P002", 1, 2, "playing"),
        ]
        assert reader.participants()[0]["status"] == "finished"
    finally:
        reader.close()
    result = CliRunner().invoke(cli, ["study", "export", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(tmp_path / "out" / "scores.csv")))
    assert [(r["policy"], r["kind"], r["steps"]) for r in rows] == [
        ("human:P001", "practice", "20"),
        ("human:P001", "battery", "20"),
    ]
    assert float(rows[1]["path_m"]) > 0.1  # it walked
    result = CliRunner().invoke(cli, ["study", "report", str(path), "--out", str(tmp_path / "report")])
    assert result.exit_code == 0, result.output
    assert "| L0 d0 s1 | humans | 0% |" in (tmp_path / "report" / "report.md").read_text()
