"""A study's trials as a participant plays them: the path the body's trunk travels, in metres,
recorded with each trial; an attempt left unfinished (the tab closed) recorded with how far it
got, exported and counted in the report, and the trial played again."""

from __future__ import annotations

import csv
import json
import math
import os
import time
from contextlib import ExitStack

import pytest
from click.testing import CliRunner

from aaai.levels import generate
from aaai.study.paths import Odometer, replay_path
from aaai.study.store import Store
from aaai.study.studyfile import load_study
from aaai_cli.main import cli

if not os.environ.get("CI"):
    pytest.importorskip("fastapi", reason="aaai study serve needs the play extra (make test installs it)")
from test_study import Client, ready  # noqa: E402  (the play extra)

WALK = """\
name: walk
battery:
  - {level: 0, difficulty: 0, seed: 1}
  - {level: 0, difficulty: 0, seed: 2}
order: fixed
time_limit: 1.4
camera_resolution: 16
"""


def test_the_odometer_sums_the_trunks_horizontal_moves_every_tenth_of_a_second_in_metres():
    odometer = Odometer(control_dt=0.02)  # a sample every 5 control steps, and the end
    for step, (x, y) in enumerate([(0.0, 0.0), (9.0, 9.0), (9.0, 9.0), (9.0, 9.0), (9.0, 9.0), (3.0, 4.0)]):
        odometer.at(step, x, y)  # steps 1 to 4 fall between samples: their sway is not counted
    odometer.at(6, 7.0, 4.0)
    odometer.end(7.0, 7.0)
    assert odometer.metres == 5.0 + 5.0  # (0, 0) to (3, 4) at step 5, then to (7, 7) at the end (1 unit = 1 m)
    coarse = Odometer(control_dt=0.02)
    for step in (0, 5, 10):  # a policy deciding every 0.1 s is sampled at each decision
        coarse.at(step, float(step), 0.0)
    assert coarse.metres == 10.0
    odometer.reset()
    odometer.at(0, 100.0, 100.0)
    assert odometer.metres == 0.0  # a new trial starts from nothing


@pytest.fixture
def served(tmp_path):
    """The WALK study with one participant, served in this process; (store, port, token, study)."""
    from aaai.study.participant import play_settings
    from aaai.study.server import StudyServer

    path = tmp_path / "study.yaml"
    path.write_text(WALK)
    links = tmp_path / "links.csv"
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1", "--out", str(links)])
    assert result.exit_code == 0, result.output
    token = links.read_text().splitlines()[1].split("?p=")[1]
    study = load_study(path)
    store = Store(study.store, study.name)
    server = StudyServer(study, store, play_settings(study, grace_seconds=0), port=0).start()
    try:
        yield store, server.port, token, study
    finally:
        server.stop()
        store.close()


def wait_for(condition, timeout: float = 10.0):
    end = time.monotonic() + timeout
    while not (found := condition()):
        assert time.monotonic() < end, "timed out"
        time.sleep(0.05)
    return found


def test_a_tab_closed_mid_trial_is_an_abandoned_attempt_and_the_trial_is_played_again_its_path_in_metres(
    served, tmp_path
):
    store, port, token, study = served
    with ExitStack() as stack:
        page = Client(stack, port, token)
        page.send({"type": "consent"})
        page.next("consented")
        page.send({"type": "start"})
        page.pump(ready)
        page.send({"type": "key", "key": "ArrowUp", "down": True})  # starts the trial and walks on
        page.pump(lambda s: s["phase"] == "running" and s["time_left"] <= 0.8)  # 0.6 s in
    # the tab is closed (--grace 0): the attempt is recorded as abandoned, with how far it got
    [left] = wait_for(lambda: [a for a in store.attempts("P001") if a["state"] != "playing"])
    assert (left["position"], left["attempt"], left["state"]) == (1, 1, "abandoned")
    assert left["reason"] == "the tab was closed" and left["started"] < left["ended"]
    assert 30 <= left["steps"] < 70 and left["seconds"] == pytest.approx(0.02 * left["steps"])
    assert left["path_m"] > 0.2 and store.trials("P001")[0]["finished"] is None
    with ExitStack() as stack:  # the same link again: the same trial, from its start
        page = Client(stack, port, token)
        assert page.joined["resuming"]
        page.send({"type": "start"})
        assert page.pump(ready)["progress"] == {"done": 0, "total": 2}
        page.send({"type": "key", "key": "ArrowUp", "down": True})
        page.pump(lambda s: s["phase"] == "ready" and s["progress"]["done"] == 1)
    first = store.trials("P001")[0]
    attempts = store.attempts("P001")
    assert [(a["position"], a["attempt"], a["state"]) for a in attempts] == [(1, 1, "abandoned"), (1, 2, "finished")]
    assert attempts[1]["steps"] == 70 and attempts[1]["path_m"] == first["path_m"]
    # the path: at least the straight line from the start to where the trunk ended, in metres
    replay = json.loads(first["replay"])
    start = generate(0, 0, 1).agent
    straight = math.hypot(replay["final_pose"]["x"] - start.x, replay["final_pose"]["y"] - start.y)
    assert straight > 0.5  # it walked
    assert straight <= first["path_m"] < 1.5 * straight  # a trot sways a little
    assert replay_path(replay) == first["path_m"]  # measured the same from the replay, as a policy's is

    result = CliRunner().invoke(cli, ["study", "export", str(study.path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(tmp_path / "out" / "attempts.csv")))
    assert [(r["participant"], r["position"], r["kind"], r["seed"], r["state"]) for r in rows] == [
        ("P001", "1", "battery", "1", "abandoned"),
        ("P001", "1", "battery", "1", "finished"),
    ]
    assert rows[0]["reason"] == "the tab was closed" and int(rows[0]["steps"]) == left["steps"]
    result = CliRunner().invoke(cli, ["study", "report", str(study.path), "--out", str(tmp_path / "report")])
    assert result.exit_code == 0, result.output
    report = {(r["scope"], r["name"]): r for r in csv.DictReader(open(tmp_path / "report" / "report.csv"))}
    assert report[("trial", "L0 d0 s1")]["abandoned"] == "1" and report[("trial", "L0 d0 s2")]["abandoned"] == "0"
    assert report[("level", "L0")]["abandoned"] == "1"


OLD_SCHEMA = """
CREATE TABLE study (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE participants (id TEXT PRIMARY KEY, number INTEGER NOT NULL UNIQUE, token TEXT NOT NULL UNIQUE,
    order_seed INTEGER NOT NULL, status TEXT NOT NULL DEFAULT 'new', created TEXT NOT NULL, consented TEXT,
    finished TEXT);
CREATE TABLE trials (participant TEXT NOT NULL REFERENCES participants(id), position INTEGER NOT NULL,
    kind TEXT NOT NULL, trial INTEGER NOT NULL, level INTEGER, difficulty INTEGER, seed INTEGER NOT NULL, arena TEXT,
    started TEXT, finished TEXT, reaction_time REAL, row TEXT, replay TEXT, PRIMARY KEY (participant, position));
INSERT INTO study VALUES ('name', 'walk');
INSERT INTO participants VALUES ('P001', 1, 'abc', 5, 'finished', '2026-01-01T00:00:00Z', NULL, NULL);
INSERT INTO trials VALUES ('P001', 1, 'battery', 0, 0, 0, 1, NULL, 'a', 'b', 0.5, '{"level": 0, "difficulty": 0,
    "seed": 1, "outcome": "failed", "steps": 20, "arena": ""}', '{"arena": null, "level": 0, "difficulty": 0,
    "seed": 1}');
"""


def test_a_store_written_before_paths_and_attempts_were_kept_is_read_and_gains_them_when_written(tmp_path):
    import sqlite3

    path = tmp_path / "study.yaml"
    path.write_text(WALK)
    study = load_study(path)
    with sqlite3.connect(study.store) as old:
        old.executescript(OLD_SCHEMA)
    reader = Store(study.store, study.name, writer=False)
    try:
        assert reader.attempts() == [] and "path_m" not in reader.trials()[0]
    finally:
        reader.close()
    result = CliRunner().invoke(cli, ["study", "export", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    [row] = list(csv.DictReader(open(tmp_path / "out" / "scores.csv")))
    assert (row["policy"], row["reaction_time"], row["path_m"]) == ("human:P001", "0.5", "")
    store = Store(study.store, study.name)  # a writer adds what is missing
    try:
        assert store.trials()[0]["path_m"] is None
        store.save_attempt("P001", 1, store.begin_attempt("P001", 1), {"steps": 3}, "abandoned", "test")
        assert [a["state"] for a in store.attempts()] == ["abandoned"]
    finally:
        store.close()
