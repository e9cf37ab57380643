"""aaai study: the study file's refusals by line, the orders, the store (WAL, one writer, a kill
mid-trial loses no finished trial), and two participants at once in headless Chromium."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack, closing
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError
from aaai.files import InUse
from aaai.study.order import battery_order, latin_square_row
from aaai.study.store import Store
from aaai.study.studyfile import load_study
from aaai_cli.main import cli

if not os.environ.get("CI"):
    pytest.importorskip("fastapi", reason="aaai study serve needs the play extra (make test installs it)")
from websockets.sync.client import connect  # noqa: E402  (the play extra)

from aaai.scoring.replays import load_replay, run_replay  # noqa: E402
from aaai.tools.play.measure import CHROMEDRIVER, CHROMIUM, FLAGS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TINY = """\
name: tiny
practice:
  - {level: 0, difficulty: 0, seed: 7}
battery:
  - {level: 0, difficulty: 0, seed: 1}
  - {level: 0, difficulty: 1, seed: 2}
order: fixed
breaks_every: 1
time_limit: 0.4
camera_resolution: 16
"""


def write_study(folder: Path, text: str = TINY) -> Path:
    path = folder / "study.yaml"
    path.write_text(text)
    return path


# --- the study file -----------------------------------------------------------------------------
def test_the_example_study_reads():
    study = load_study(ROOT / "examples" / "study" / "pilot.yaml")
    assert study.order == "counterbalanced" and len(study.battery) == 6 and study.practice
    assert not any(study.show.values())  # map, coordinates, seed, returns: all off


@pytest.mark.parametrize(
    "change, expected",
    [
        ("order: fixed", None),
        ("order: shuffled", "line 7, order: got 'shuffled'; allowed: fixed, random, counterbalanced"),
        ("breaks_every: -1", "line 8, breaks_every: got -1; allowed: 0 (no breaks)"),
        ("time_limit: 0", "line 9, time_limit: got 0; allowed: seconds per trial, over 0"),
        ("camera_resolution: 4", "line 10, camera_resolution: got 4; allowed: a whole number 8 to 512"),
        ("colour: red", "line 11, colour: unknown key 'colour'; allowed: name, battery"),
        ("show: {map: 1}", "line 11, show.map: got 1; allowed: true or false"),
        ("show: {answers: true}", "line 11, show.answers: unknown key 'answers'; allowed: map, coordinates"),
        ("texts: {consent: ''}", "line 11, texts.consent: got ''; allowed: text of 1 to 5000 characters"),
        ("store: postgresql+psycopg://me@db.example.org/study", None),
        ("store: postgresql+psycopg://me:secret@db/x", "line 11, store: a password in the study file's address;"),
        ("store: mysql://db/x", "line 11, store: got 'mysql://db/x'; allowed: a file name, or postgresql+psycopg://"),
    ],
)
def test_a_bad_study_file_is_refused_by_line_naming_the_key_value_and_what_is_allowed(tmp_path, change, expected):
    text = TINY
    key = change.split(":")[0]
    if key in ("order", "breaks_every", "time_limit", "camera_resolution"):
        text = "\n".join(change if line.startswith(key + ":") else line for line in TINY.splitlines()) + "\n"
    else:
        text = TINY + change + "\n"
    path = write_study(tmp_path, text)
    if expected is None:
        load_study(path)
        return
    with pytest.raises(ConfigError) as raised:
        load_study(path)
    assert f"study.yaml {expected}" in str(raised.value)


@pytest.mark.parametrize(
    "battery, expected",
    [
        ("[{level: 0, seed: -3}]", "line 5, battery[0].seed: got -3; allowed: a whole number 0 to"),
        ("[{level: 99}]", "line 5, battery[0].level: level 99 does not exist; allowed:"),
        ("[{level: 0, difficulty: 11}]", "line 5, battery[0].difficulty: got 11; allowed: a whole number 0 to 10"),
        ("[{level: 0, speed: 2}]", "line 5, battery[0].speed: unknown key 'speed'; allowed: level, difficulty"),
        ("[{arena: nowhere.yaml}]", "line 5, battery[0].arena: got 'nowhere.yaml'; allowed: an arena file"),
        ("[]", "line 4, battery: got []; allowed: a list of 1 to 1000 trials"),
    ],
)
def test_a_bad_trial_is_refused_by_line(tmp_path, battery, expected):
    lines = TINY.splitlines()
    start = lines.index("battery:")
    text = "\n".join(
        lines[:start] + [f"battery:\n  {battery}" if battery != "[]" else "battery: []"] + lines[start + 3 :]
    )
    with pytest.raises(ConfigError) as raised:
        load_study(write_study(tmp_path, text + "\n"))
    assert f"study.yaml {expected}" in str(raised.value)


def test_an_arena_trial_is_read_relative_to_the_study_file(tmp_path):
    arena = ROOT / "configs" / "arenas" / sorted(p.name for p in (ROOT / "configs" / "arenas").glob("*.yaml"))[0]
    shutil.copyfile(arena, tmp_path / "mine.yaml")
    study = load_study(write_study(tmp_path, TINY.replace("{level: 0, difficulty: 1, seed: 2}", "{arena: mine.yaml}")))
    assert study.battery[1].arena == (tmp_path / "mine.yaml").resolve()


def test_the_commands_refuse_a_bad_study_file_or_a_missing_store_with_one_message(tmp_path):
    path = write_study(tmp_path, TINY.replace("order: fixed", "order: sideways"))
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "2"])
    assert result.exit_code == 2 and "line 7, order: got 'sideways'" in result.output
    assert "Traceback" not in result.output
    path = write_study(tmp_path)
    result = CliRunner().invoke(cli, ["study", "export", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "study store" in result.output and "does not exist" in result.output
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1", "--url", "ftp://x/"])
    assert result.exit_code == 2 and "--url: got 'ftp://x/'" in result.output
    assert CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1"]).exit_code == 0
    write_study(tmp_path, TINY.replace("seed: 2}", "seed: 3}"))  # the battery changed under its participants
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1"])
    assert result.exit_code == 2 and "its practice, battery or order changed since" in result.output


def test_a_postgresql_store_that_cannot_be_reached_is_one_message(tmp_path):
    pytest.importorskip("psycopg", reason="the PostgreSQL store needs psycopg (the play extra)")
    path = write_study(tmp_path, TINY + "store: postgresql+psycopg://aaai@127.0.0.1:1/nothing\n")
    assert load_study(path).store == "postgresql+psycopg://aaai@127.0.0.1:1/nothing"
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1"])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "study store 'postgresql+psycopg://aaai@127.0.0.1:1/nothing': connection failed" in result.output


def test_feedback_and_reaction_time_in_plain_terms():
    from aaai.study.participant import feedback_of, first_move

    assert feedback_of({"outcome": "succeeded", "food_eaten": 1}, "ate green") == "You found the food!"
    assert feedback_of({"outcome": "failed", "food_eaten": 0}, "time") == "Time is up."
    assert feedback_of({"outcome": "failed", "food_eaten": 0}, "fell").startswith("Oops, you fell")
    assert first_move([[0, 0, 0]] * 12 + [[1, 0, 0]], 0.02) == 0.24  # the 13th step is 0.24 s in
    assert first_move([[0, 0, 0]] * 5, 0.02) is None


# --- the order ----------------------------------------------------------------------------------
def test_fixed_order_is_the_files_for_everyone():
    assert battery_order("fixed", 5, 3, 1234) == [0, 1, 2, 3, 4]


def test_random_order_is_reproducible_from_its_recorded_seed_and_differs_between_seeds():
    orders = {tuple(battery_order("random", 8, 0, seed)) for seed in range(20)}
    assert battery_order("random", 8, 0, 42) == battery_order("random", 8, 7, 42)  # the seed decides, not the index
    assert len(orders) > 15 and all(sorted(order) == list(range(8)) for order in orders)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_counterbalanced_order_puts_every_trial_in_every_position_equally_often(n):
    rows = [battery_order("counterbalanced", n, index, 0) for index in range(2 * n)]
    for position in range(n):
        counts = [sum(row[position] == trial for row in rows) for trial in range(n)]
        assert counts == [2] * n, (position, rows)
    follows = [
        sum(row[i] == a and row[i + 1] == b for row in rows for i in range(n - 1))
        for a in range(n)
        for b in range(n)
        if a != b
    ]
    assert set(follows) == {2 if n % 2 == 0 else 1} or (n % 2 and min(follows) >= 1)  # balanced for carry-over
    assert latin_square_row(n, 0) != latin_square_row(n, 1)


# --- the store ----------------------------------------------------------------------------------
def test_the_store_is_wal_with_one_writer_and_gives_each_participant_a_token_and_order(tmp_path):
    study = load_study(write_study(tmp_path, TINY.replace("order: fixed", "order: random")))
    store = Store(study.store, study.name, serving=True)
    try:
        assert store.journal_mode() == "wal"
        with pytest.raises(InUse, match=f"is being served by process {os.getpid()} .*one server per store"):
            Store(study.store, study.name, serving=True)
        added = store.add_participants(study, 3)
        assert [p["id"] for p in added] == ["P001", "P002", "P003"]
        assert len({p["token"] for p in added}) == 3 and all(len(p["token"]) >= 24 for p in added)
        for participant in added:
            trials = store.trials(participant["id"])
            assert [t["kind"] for t in trials] == ["practice", "battery", "battery"]
            expected = battery_order("random", 2, 0, participant["order_seed"])
            assert [t["trial"] for t in trials[1:]] == expected  # the order comes back from the recorded seed
        assert store.participant(added[1]["token"])["id"] == "P002" and store.participant("guess") is None
    finally:
        store.close()
    with pytest.raises(ConfigError, match="holds study 'tiny', not 'other'"):
        Store(study.store, "other", writer=False)


def test_a_write_waits_for_another_writers_transaction_and_is_refused_naming_it_if_it_never_ends(tmp_path, monkeypatch):
    import threading

    from aaai.files import hold
    from aaai.study import store as store_module

    study = load_study(write_study(tmp_path))
    store = Store(study.store, study.name)
    try:
        [added] = store.add_participants(study, 1)
        other = hold(store.write_lock_path, lambda pid: "held")  # another process's write transaction
        writing = threading.Thread(target=store.consent, args=(added["id"],))
        writing.start()
        time.sleep(0.3)
        assert writing.is_alive() and store.participants()[0]["status"] == "new"  # it waits its turn
        other.release()
        writing.join(5)
        assert store.participants()[0]["status"] == "consented"  # then writes
        monkeypatch.setattr(store_module, "WRITE_WAIT", 0.2)
        with hold(store.write_lock_path, lambda pid: "held"):
            with pytest.raises(InUse, match=f"is being written by process {os.getpid()} and was for over 0.2 s"):
                store.finish(added["id"])
        assert store.participants()[0]["status"] == "consented"
    finally:
        store.close()


# --- serving: a WebSocket client, and the server killed mid-trial ----------------------------------
class Client:
    def __init__(self, stack: ExitStack, port: int, token: str):
        origin = f"http://127.0.0.1:{port}"
        self.ws = stack.enter_context(connect(f"ws://127.0.0.1:{port}/ws", origin=origin, max_size=None))
        self.send({"type": "join", "token": token})
        self.joined = self.next("joined")
        self.status: dict = {}

    def send(self, message: dict) -> None:
        self.ws.send(json.dumps(message))

    def next(self, kind: str, timeout: float = 10.0) -> dict:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            message = self.ws.recv(end - time.monotonic())
            if isinstance(message, str) and json.loads(message)["type"] == kind:
                return json.loads(message)
        raise AssertionError(f"no {kind} message")

    def pump(self, until, timeout: float = 15.0) -> dict:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                message = self.ws.recv(0.2)
            except TimeoutError:
                continue
            if isinstance(message, bytes):
                continue
            data = json.loads(message)
            if data["type"] == "error":
                raise AssertionError(data["message"])
            if data["type"] in ("frame", "status"):
                self.status = data
                if data["type"] == "frame":
                    self.send({"type": "ack", "frame": data["frame"]})
                if until(data):
                    return data
        raise AssertionError(f"timed out; last status {self.status}")


def ready(status: dict) -> bool:
    return status["phase"] == "ready" and status["accepts_start"]


def serve_in_subprocess(study_path: Path) -> tuple[subprocess.Popen, int]:
    process = subprocess.Popen(
        [sys.executable, "-m", "aaai_cli.main", "study", "serve", str(study_path), "--port", "0", "--grace", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert process.stdout is not None
    line = process.stdout.readline()
    assert "serving 'tiny' at http://127.0.0.1:" in line, line
    return process, int(line.split("http://127.0.0.1:")[1].split("/")[0])


def test_a_server_killed_mid_trial_loses_no_finished_trial_and_the_participant_resumes_at_the_next(tmp_path):
    path = write_study(tmp_path)
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1", "--url", "http://127.0.0.1:1/"])
    assert result.exit_code == 0, result.output
    [link] = list(csv.DictReader(open(tmp_path / "study_links.csv")))
    token = link["link"].split("?p=")[1]
    process, port = serve_in_subprocess(path)
    try:
        with ExitStack() as stack:
            page = Client(stack, port, token)
            assert not page.joined["consented"]
            page.send({"type": "consent"})
            page.next("consented")
            page.send({"type": "start"})
            page.pump(ready)
            page.send({"type": "key", "key": " ", "down": True})  # the practice trial: 0.4 s, then "Time is up"
            status = page.pump(lambda s: s["phase"] == "ready" and s["kind"] == "battery")
            assert status["feedback"] == "Time is up." and status["first_battery"]
            time.sleep(1.05)  # keys start a trial a second after the last one ended (a held key is no start)
            page.send({"type": "key", "key": "ArrowUp", "down": True})  # the first battery trial starts
            page.pump(lambda s: s["phase"] == "running")
            reader = stack.enter_context(closing(Store(load_study(path).store, "tiny", writer=False)))
            end = time.monotonic() + 5
            while len(reader.attempts("P001")) < 2:  # its attempt has begun
                assert time.monotonic() < end, reader.attempts("P001")
                time.sleep(0.02)
            os.kill(process.pid, signal.SIGKILL)  # mid-trial
            process.wait(10)
    finally:
        process.kill()
        process.wait(10)
    study = load_study(path)
    store = Store(study.store, study.name)  # the killed server's lock is gone with it
    try:
        trials = store.trials("P001")
        assert trials[0]["finished"] and json.loads(trials[0]["row"])["steps"] == 20
        assert trials[0]["path_m"] is not None
        assert json.loads(trials[0]["replay"])["steps"] == 20
        assert trials[1]["started"] and trials[1]["finished"] is None  # the trial killed mid-way
        assert trials[2]["started"] is None
        attempts = store.attempts("P001")
        assert [(a["position"], a["state"]) for a in attempts] == [(1, "finished"), (2, "playing")]
    finally:
        store.close()
    process, port = serve_in_subprocess(path)  # served again: the link resumes at the unfinished trial
    try:
        with ExitStack() as stack:
            page = Client(stack, port, token)
            assert page.joined["consented"] and page.joined["resuming"]
            page.send({"type": "start"})
            status = page.pump(lambda s: s["phase"] == "ready")
            assert status["kind"] == "battery" and status["progress"] == {"done": 0, "total": 2}
            # participants added while it serves: their links work at once, without a restart
            result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "1"])
            assert result.exit_code == 0, result.output
            rows = list(csv.DictReader(open(tmp_path / "study_links.csv")))
            assert [row["id"] for row in rows] == ["P001", "P002"] and rows[0]["link"].endswith(token)
            newcomer = Client(stack, port, rows[1]["link"].split("?p=")[1])
            assert newcomer.joined["participant"] == "P002" and not newcomer.joined["consented"]
            newcomer.send({"type": "consent"})  # the server writes beside the command that added it
            newcomer.next("consented")
            with pytest.raises(InUse, match=f"is being served by process {process.pid} "):
                Store(study.store, study.name, serving=True)  # a second server of the store
            reader = Store(study.store, study.name, writer=False)
            try:  # the attempt its killed predecessor left playing: interrupted, at its last saved progress
                killed = reader.attempts("P001")[1]
                assert (killed["position"], killed["state"]) == (2, "interrupted")
                assert killed["reason"].startswith("the server stopped") and killed["ended"] == killed["saved"]
            finally:
                reader.close()
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()


# --- two participants at once in headless Chromium ------------------------------------------------
@pytest.mark.skipif(
    not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()) and not os.environ.get("CI"),
    reason="needs Debian's chromium and chromium-driver (make test installs them; on CI it never skips)",
)
def test_two_participants_play_a_study_at_once_in_a_browser_and_their_rows_and_replays_land(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from aaai.study.participant import play_settings
    from aaai.study.server import StudyServer

    path = write_study(tmp_path)
    result = CliRunner().invoke(cli, ["study", "participants", str(path), "-n", "2"])
    assert result.exit_code == 0, result.output
    study = load_study(path)
    store = Store(study.store, study.name)
    server = StudyServer(study, store, play_settings(study, grace_seconds=30), port=0).start()
    links = {
        row["id"]: row["link"].replace(":8000/", f":{server.port}/")
        for row in csv.DictReader(open(tmp_path / "study_links.csv"))
    }
    profiles, drivers = [], {}
    try:
        for pid in links:
            options = webdriver.ChromeOptions()
            options.binary_location = CHROMIUM
            profiles.append(tempfile.mkdtemp(prefix="aaai-chromium-"))
            for flag in (*FLAGS, f"--user-data-dir={profiles[-1]}"):
                options.add_argument(flag)
            drivers[pid] = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)

        def phase(driver) -> str:
            return driver.find_element(By.TAG_NAME, "body").get_attribute("data-phase")

        def wait(condition, timeout=15.0):
            end = time.monotonic() + timeout
            while not condition():
                assert time.monotonic() < end, {
                    pid: (phase(d), d.find_element(By.ID, "screen").text) for pid, d in drivers.items()
                }
                time.sleep(0.05)

        def start_round(driver) -> None:
            wait(lambda: phase(driver) == "ready" and "Press Space" in driver.find_element(By.ID, "screen-text").text)
            ActionChains(driver).send_keys(Keys.SPACE).perform()

        for pid, driver in drivers.items():  # both open their links: consent, then instructions
            driver.get(links[pid])
        for driver in drivers.values():
            wait(lambda: phase(driver) == "consent")
            assert "voluntary" in driver.find_element(By.ID, "screen-text").text
            driver.find_element(By.ID, "agree").click()
            wait(lambda: phase(driver) == "instructions")
            assert "1 practice round" in driver.find_element(By.ID, "screen-text").text
            driver.find_element(By.ID, "start").click()
        for driver in drivers.values():  # the practice rounds, side by side
            start_round(driver)
            assert driver.find_element(By.ID, "round").text == "Practice"
        for driver in drivers.values():
            wait(lambda: phase(driver) == "ready")
            wait(lambda: "Time is up" in driver.find_element(By.ID, "feedback").text)
            assert "practice is over" in driver.find_element(By.ID, "screen-text").text
            # a participant's page shows no map, coordinates, seed, returns or file names
            assert not driver.find_element(By.ID, "map").is_displayed()
            assert not driver.find_element(By.ID, "extra").is_displayed()
            text = driver.find_element(By.TAG_NAME, "body").text.lower()
            for hidden in ("seed", "heading", "x ", "return", ".csv", ".yaml", "sqlite", "d0", "l0"):
                assert hidden not in text, (hidden, text)
        first, second = drivers.values()
        first.get("about:blank")  # P001 closes the tab ...
        first.get(links["P001"])  # ... and comes back with the same link: on at the first battery round
        wait(lambda: phase(first) == "instructions")
        assert "Welcome back" in first.find_element(By.ID, "screen-text").text
        first.find_element(By.ID, "start").click()
        for driver in (first, second):  # battery round 1, then a break, then round 2
            start_round(driver)
        for driver in (first, second):
            wait(lambda: phase(driver) == "ready" and "break" in driver.find_element(By.ID, "screen-title").text)
            assert driver.find_element(By.ID, "progress").get_attribute("value") == "1"
            start_round(driver)
        for driver in (first, second):
            wait(lambda: phase(driver) == "finished")
            assert "You have finished" in driver.find_element(By.ID, "screen-text").text
        first.get(links["P001"])  # a finished link is refused with a plain page
        assert "already taken part" in first.find_element(By.TAG_NAME, "h1").text
    finally:
        for driver in drivers.values():
            driver.quit()
        server.stop()
        store.close()
        for profile in profiles:
            shutil.rmtree(profile, ignore_errors=True)

    result = CliRunner().invoke(cli, ["study", "export", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(tmp_path / "out" / "scores.csv")))
    assert [(r["policy"], r["position"], r["kind"]) for r in rows] == [
        (f"human:{pid}", str(position), kind)
        for pid in ("P001", "P002")
        for position, kind in ((1, "practice"), (2, "battery"), (3, "battery"))
    ]
    assert [(r["difficulty"], r["seed"]) for r in rows[:3]] == [("0", "7"), ("0", "1"), ("1", "2")]
    assert all(r["steps"] == "20" and r["reaction_time"] == "" for r in rows)  # nobody moved: no reaction time
    assert all(0 <= float(r["path_m"]) < 0.5 for r in rows)  # nor walked: the trunk only settled
    replays = sorted((tmp_path / "out" / "replays").iterdir())
    assert len(replays) == 6 and replays[0].name.startswith("P001_001_")
    replay = load_replay(replays[1])
    assert replay["policy"] == "human:P001" and replay["seed"] == 1
    assert run_replay(replay).differences == []  # `aaai show --replay` plays it back
    result = CliRunner().invoke(cli, ["run", "--replay", str(replays[1])])
    assert result.exit_code == 0 and "reproduced bit for bit" in result.output, result.output
