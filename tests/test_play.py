"""aaai play: the page in a real browser (headless Chromium through Selenium), sessions side by
side, bad messages, a closed tab, resuming a battery, and replays run again bit for bit."""

from __future__ import annotations

import csv
import json
import os
import shutil
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.config import ConfigError, load_config
from aaai.scoring.evaluation import Cell
from aaai_cli.main import cli

if not os.environ.get("CI"):  # on CI (make test installs the play extra) a missing library fails, never skips
    pytest.importorskip("fastapi", reason="aaai play needs the play extra (make test installs it)")
from websockets.sync.client import connect  # noqa: E402  (the play extra)

from aaai.scoring.replays import load_replay, run_replay  # noqa: E402
from aaai.tools.play.measure import CHROMEDRIVER as CHROMEDRIVER_PATH  # noqa: E402
from aaai.tools.play.measure import CHROMIUM as CHROMIUM_PATH  # noqa: E402
from aaai.tools.play.measure import FLAGS as CHROMIUM_FLAGS  # noqa: E402
from aaai.tools.play.server import Server  # noqa: E402
from aaai.tools.play.session import InputError, PlaySettings, abandoned_path, command_of, control_of  # noqa: E402

CHROMIUM, CHROMEDRIVER = Path(CHROMIUM_PATH), Path(CHROMEDRIVER_PATH)
ROOT_ARENAS = Path(__file__).resolve().parent.parent / "configs" / "arenas"


def settings_for(folder: Path, seeds=(0,), max_steps: int = 100, **changes) -> PlaySettings:
    config = load_config(None, camera=True, action_mode="gait", decision_interval=0.02, max_steps=max_steps)
    values = dict(
        config=config,
        cells=[Cell(0, 0, list(seeds))],
        output=str(folder / "human_{player}.csv"),
        replays=folder / "replays",
        between_seconds=0.0,
        grace_seconds=0.0,
    )
    values.update(changes)
    return PlaySettings(**values)


def rows_of(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


class Page:
    """A page's side of the socket, in Python: sends keys, acknowledges frames, reads the status."""

    def __init__(self, stack: ExitStack, server: Server):
        origin = server.url.split("/?")[0].rstrip("/")  # the page's own origin, as a browser sends it
        self.ws = stack.enter_context(connect(server.url.replace("http", "ws") + "ws", origin=origin, max_size=None))
        self.hello = json.loads(self.ws.recv(5))
        self.status: dict = {}
        self.errors: list[str] = []
        self.joined: dict | None = None

    def send(self, message) -> None:
        self.ws.send(message if isinstance(message, str) else json.dumps(message))

    def key(self, key: str, down: bool = True) -> None:
        self.send({"type": "key", "key": key, "down": down})

    def join(self, player: str, token: str | None = None) -> None:
        self.send({"type": "join", "player": player, "token": token})

    def pump(self, until=lambda status: False, timeout: float = 10.0) -> dict:
        """Reads messages (acknowledging frames) until ``until(status)`` or the timeout."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                message = self.ws.recv(max(0.01, min(0.2, end - time.monotonic())))
            except TimeoutError:
                continue
            if isinstance(message, bytes):
                continue
            data = json.loads(message)
            if data["type"] == "error":
                self.errors.append(data["message"])
            elif data["type"] == "joined":
                self.joined = data
            elif data["type"] in ("frame", "status"):
                self.status = data
                if data["type"] == "frame":
                    self.send({"type": "ack", "frame": data["frame"]})
            if self.status and until(self.status):
                return self.status
        raise AssertionError(f"timed out; last status {self.status}, errors {self.errors}")

    def settle(self, seconds: float) -> dict:
        """Reads every message for ``seconds``; the last status."""
        try:
            self.pump(timeout=seconds)
        except AssertionError:
            pass
        return self.status


def startable(status: dict) -> bool:
    return status["phase"] == "ready" and status["accepts_start"]


def over(status: dict) -> bool:
    return status["phase"] in ("finished", "error", "abandoned")


def test_keys_and_commands():
    assert control_of("ArrowUp") == "forward" and control_of("W") == "forward" and control_of(" ") is None
    with pytest.raises(InputError, match="key: got 'q'; allowed: 'ArrowUp'"):
        control_of("q")
    assert command_of({"forward", "left", "crouch"}) == (1.0, 1.0, 1.0)
    assert command_of({"forward", "backward", "right"}) == (0.0, -1.0, 0.0)  # opposite keys cancel


@pytest.mark.skipif(
    not (CHROMIUM.exists() and CHROMEDRIVER.exists()) and not os.environ.get("CI"),
    reason="needs Debian's chromium and chromium-driver (make test installs them; on CI it never skips)",
)
def test_browser_plays_an_episode_scores_it_and_its_replay_runs_again_bit_for_bit(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    server = Server(settings_for(tmp_path, max_steps=500), port=0).start()
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    profile = tempfile.mkdtemp(prefix="aaai-chromium-")
    for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):  # the flags `aaai play`'s measure uses
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    try:
        driver.get(server.url)
        phase = lambda: driver.find_element(By.ID, "phase").get_attribute("data-phase")  # noqa: E731

        def pose() -> tuple[float, float, float]:
            element = driver.find_element(By.ID, "pose")
            return tuple(float(element.get_attribute(f"data-{k}")) for k in ("x", "y", "yaw"))

        def wait(condition, timeout=10.0):
            end = time.monotonic() + timeout
            while not condition():
                assert time.monotonic() < end, (
                    f"timed out; phase {phase()}, error {driver.find_element(By.ID, 'error').text!r}"
                )
                time.sleep(0.05)

        wait(lambda: driver.find_element(By.ID, "player").is_displayed())
        driver.find_element(By.ID, "player").send_keys("../up", Keys.ENTER)  # not a plain name: the page says so
        refusal = "player: got '../up'; allowed: 1 to 40 letters (A-Z, a-z), digits, '-' or '_'"
        wait(lambda: driver.find_element(By.ID, "screen-text").text == refusal)
        assert driver.find_element(By.ID, "player").is_displayed()
        driver.find_element(By.ID, "player").clear()
        driver.find_element(By.ID, "player").send_keys("alice", Keys.ENTER)
        wait(lambda: phase() == "ready")
        assert "Walk to the green ball" in driver.find_element(By.ID, "task").text
        start = pose()
        actions = ActionChains(driver)
        actions.key_down(Keys.ARROW_UP).perform()  # starts the episode and walks north (the agent faces north)
        wait(lambda: phase() == "running")
        time.sleep(0.3)
        driver.save_screenshot(str(tmp_path / "play.png"))
        time.sleep(1.2)
        x, y, yaw = pose()
        assert y > start[1] + 0.5, f"ArrowUp walks forward (north): y {start[1]} -> {y}"
        assert abs(x - start[0]) < 1.0 and abs(yaw - start[2]) < 20
        actions.key_down("c").perform()  # crouch to reach the food on the floor
        wait(phase_is_over := lambda: phase() == "finished", timeout=20)
        ActionChains(driver).key_up("c").key_up(Keys.ARROW_UP).perform()
        assert phase_is_over()
    finally:
        driver.quit()
        server.stop()
        shutil.rmtree(profile, ignore_errors=True)
    if os.environ.get("AAAI_PLAY_SCREENSHOT"):  # make play-screenshot: the README's picture of the page
        shutil.copyfile(tmp_path / "play.png", os.environ["AAAI_PLAY_SCREENSHOT"])

    [row] = rows_of(tmp_path / "human_alice.csv")
    assert (row["level"], row["difficulty"], row["seed"]) == ("0", "0", "0")
    assert row["food_eaten"] == "1" and row["outcome"] == "succeeded", row  # walked to the food and ate it
    assert float(row["wall_seconds"]) >= int(row["steps"]) * 0.02 - 0.05  # never faster than real time
    record = json.loads((tmp_path / "human_alice_scored_with.json").read_text())
    assert record["policy"] == "human:alice"

    # The recorded episode runs again bit for bit, in Python and through `aaai run --replay`.
    [replay_file] = (tmp_path / "replays").iterdir()
    replay = load_replay(replay_file)
    assert replay["policy"] == "human:alice" and replay["steps"] == int(row["steps"])
    outcome = run_replay(replay)
    assert outcome.differences == []
    assert outcome.result.episode_return == replay["return"] and round(replay["return"], 6) == float(row["return"])
    assert outcome.final_pose == replay["final_pose"]
    result = CliRunner().invoke(cli, ["run", "--replay", str(replay_file)])
    assert result.exit_code == 0, result.output
    assert "reproduced bit for bit" in result.output


def test_two_sessions_play_side_by_side_and_bad_input_changes_nothing(tmp_path):
    server = Server(settings_for(tmp_path, max_steps=100), port=0).start()
    try:
        with ExitStack() as stack:
            ann, bob, intruder = Page(stack, server), Page(stack, server), Page(stack, server)
            assert "ArrowUp" in ann.hello["keys"]
            intruder.key("ArrowUp")  # no session yet: refused
            ann.join("ann")
            bob.join("bob")
            ann.pump(startable)
            bob.pump(startable)
            intruder.join("ann")  # a second tab cannot take (or steer) ann's session
            intruder.join("../etc")
            deadline = time.monotonic() + 2
            while len(intruder.errors) < 3 and time.monotonic() < deadline:
                try:
                    message = json.loads(intruder.ws.recv(0.2))
                    if message["type"] == "error":
                        intruder.errors.append(message["message"])
                except TimeoutError:
                    pass
            assert "before join" in intruder.errors[0]
            assert "playing in another tab" in intruder.errors[1]
            assert "player: got '../etc'" in intruder.errors[2]
            start_ann, start_bob = ann.status["pose"], bob.status["pose"]
            ann.key("ArrowUp")
            bob.key("ArrowLeft")
            for bad in (
                "not json",
                json.dumps([1]),
                json.dumps({"type": "key", "key": "q", "down": True}),
                json.dumps({"type": "key", "key": "w", "down": "yes"}),
                json.dumps({"type": "warp"}),
            ):
                ann.send(bad)
            end_ann = ann.pump(over)
            end_bob = bob.pump(over)
    finally:
        server.stop()
    assert [e.split(":")[0] for e in ann.errors] == ["message", "message type", "key", "key message", "message type"]
    assert end_ann["phase"] == end_bob["phase"] == "finished"
    assert end_ann["pose"]["y"] > start_ann["y"] + 0.5 and abs(end_ann["pose"]["yaw_deg"] - start_ann["yaw_deg"]) < 20
    assert abs(end_bob["pose"]["yaw_deg"] - start_bob["yaw_deg"]) > 20  # bob turned on the spot ...
    assert abs(end_bob["pose"]["y"] - start_bob["y"]) < 1.0  # ... and did not walk ann's way
    for name in ("ann", "bob"):
        [row] = rows_of(tmp_path / f"human_{name}.csv")
        assert row["steps"] == "100" and float(row["wall_seconds"]) >= 2.0 - 0.05  # real time, not faster
    replays = {json.loads(path.read_text())["policy"]: path for path in (tmp_path / "replays").iterdir()}
    assert sorted(replays) == ["human:ann", "human:bob"]


def test_lost_focus_pauses_a_closed_tab_is_abandoned_not_scored_and_the_battery_resumes(tmp_path):
    server = Server(settings_for(tmp_path, seeds=(0, 1), max_steps=50), port=0).start()
    try:
        with ExitStack() as stack:
            page = Page(stack, server)
            page.join("cat")
            page.pump(startable)
            page.key(" ")
            page.pump(lambda s: s["phase"] == "ready" and s["episode"]["index"] == 2 and s["accepts_start"])
            page.key("ArrowUp")
            page.pump(lambda s: s["phase"] == "running" and s["steps"] > 3)
            page.send({"type": "focus", "focused": False})  # the page loses focus: the clock stops
            page.pump(lambda s: s["phase"] == "paused")
            paused = dict(page.settle(0.3))  # a step whose action was chosen before the focus went lands; then none
            assert paused["phase"] == "paused"
            page.key(" ")  # keys do not resume a page without focus
            status = page.settle(0.5)
            assert status["phase"] == "paused" and status["steps"] == paused["steps"]
            page.send({"type": "focus", "focused": True})
            page.key(" ")
            page.pump(lambda s: s["phase"] == "running" and s["steps"] > paused["steps"])
        # the tab is gone mid-episode: with no grace period, its episode is abandoned at once
        deadline, path = time.monotonic() + 5, abandoned_path(tmp_path / "human_cat.csv")
        while not (path.exists() and rows_of(path)):  # the file may appear a moment before its row
            assert time.monotonic() < deadline, "the closed tab's episode was not logged as abandoned"
            time.sleep(0.05)
        [abandoned] = rows_of(path)
        assert (abandoned["seed"], abandoned["player"]) == ("1", "cat") and "closed" in abandoned["reason"]
        assert [row["seed"] for row in rows_of(tmp_path / "human_cat.csv")] == ["0"]  # scores only
        with ExitStack() as stack:  # the player comes back: the battery resumes at the unplayed episode
            page = Page(stack, server)
            page.join("cat")
            status = page.pump(startable)
            assert (status["episode"]["index"], status["episode"]["seed"]) == (2, 1)
        with pytest.raises(ConfigError, match=r"--port: got \d+, and 127.0.0.1:\d+ is in use"):
            Server(settings_for(tmp_path), port=int(server.url.rsplit(":", 1)[1].strip("/")))
    finally:
        server.stop()


def test_eval_replays_run_and_film_again_and_a_changed_replay_is_caught(tmp_path):
    (tmp_path / "short.yaml").write_text("episode:\n  max_steps: 40\n")
    runner = CliRunner()
    result = runner.invoke(
        cli,
        [
            "eval",
            "--seeds",
            "5",
            "--policy",
            "random",
            "--levels",
            "1",
            "--difficulty",
            "3",
            "--config",
            str(tmp_path / "short.yaml"),
            "--out",
            str(tmp_path / "sb.csv"),
            "--save-replays",
            str(tmp_path / "replays"),
        ],
    )
    assert result.exit_code == 0, result.output
    path = tmp_path / "replays" / "L1_d3_s5.json"
    result = runner.invoke(cli, ["run", "--replay", str(path)])
    assert result.exit_code == 0 and "reproduced bit for bit" in result.output, result.output
    result = runner.invoke(cli, ["show", "--video", str(tmp_path / "r.avi"), "--replay", str(path)])
    assert result.exit_code == 0 and "ended at step 40" in result.output, result.output

    replay = json.loads(path.read_text())
    replay["actions"][0][1][0] = -replay["actions"][0][1][0] or 0.5  # one action changed: another episode
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps(replay))
    result = runner.invoke(cli, ["run", "--replay", str(changed)])
    assert result.exit_code == 1 and "does not reproduce the recorded episode" in result.output, result.output
    replay["config"]["physics"]["gravity"] = 5.0  # an edited config no longer matches its digest
    changed.write_text(json.dumps(replay))
    with pytest.raises(ConfigError, match="key 'config_digest'"):
        load_replay(changed)
    changed.write_text("{}")
    with pytest.raises(ConfigError, match="is not an aaai replay"):
        load_replay(changed)


def test_play_command_refuses_bad_options_and_a_port_in_use(tmp_path):
    import socket

    runner = CliRunner()
    for args, message in (
        (["1", "--levels", "2"], "use one or the other"),
        (["--out", "one.csv"], "without {player}"),
        (["--player", "a b"], "player: got 'a b'"),
        (["L9", "-d", "11"], "'-d': 11 is not in the range 0<=x<=10"),
        (["--arena", str(ROOT_ARENAS), "--levels", "1"], "an arena file is its own level"),
    ):
        result = runner.invoke(cli, ["play", *args])
        assert result.exit_code == 2 and message in result.output, (args, result.output)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = runner.invoke(cli, ["play", "--port", str(port), "--out", str(tmp_path / "h_{player}.csv")])
    assert result.exit_code == 2 and f"--port: got {port}, and 127.0.0.1:{port} is in use" in result.output, (
        result.output
    )


def test_a_dropped_connection_pauses_and_the_tab_carries_on_with_its_token(tmp_path):
    server = Server(settings_for(tmp_path, max_steps=60, grace_seconds=30.0), port=0).start()
    try:
        with ExitStack() as stack:
            page = Page(stack, server)
            page.join("eve")
            page.pump(startable)
            page.key("ArrowUp")
            page.pump(lambda s: s["phase"] == "running" and s["steps"] > 5)
            page.pump(lambda s: page.joined is not None, timeout=1)
            token = page.joined["token"]
        deadline = time.monotonic() + 5
        while server.registry.all()[0].status()["phase"] != "paused":  # the socket dropped: the clock stops
            assert time.monotonic() < deadline
            time.sleep(0.02)
        steps = server.registry.all()[0].status()["steps"]
        time.sleep(0.3)
        assert server.registry.all()[0].status()["steps"] == steps
        with ExitStack() as stack:
            page = Page(stack, server)
            page.join("eve", token)  # the same tab, reconnected
            status = page.pump(lambda s: s["type"] == "frame")  # it gets the picture at once, paused
            assert status["phase"] == "paused" and status["steps"] == steps
            page.key(" ")
            end = page.pump(over)
    finally:
        server.stop()
    assert end["phase"] == "finished" and not abandoned_path(tmp_path / "human_eve.csv").exists()
    [row] = rows_of(tmp_path / "human_eve.csv")
    assert row["steps"] == "60"


def test_a_battery_of_arena_files_is_played_and_scored_with_its_arena_column(tmp_path):
    arena = ROOT_ARENAS / "l0_food_ahead.yaml"
    server = Server(settings_for(tmp_path, max_steps=40, cells=[], arenas=[arena], arena_seeds=[0, 1]), port=0).start()
    try:
        with ExitStack() as stack:
            page = Page(stack, server)
            page.join("eve")
            for index in (1, 2):
                page.pump(lambda s, i=index: startable(s) and s["episode"]["index"] == i)
                for _ in range(3):  # a press seen once lost under a load of 10 on 2 cores: a player presses again
                    page.key(" ")
                    page.key(" ", down=False)
                    try:
                        page.pump(lambda s: s["phase"] != "ready", timeout=3.0)
                        break
                    except AssertionError:
                        continue
                status = page.pump(lambda s, i=index: s["scored"] == i)
    finally:
        server.stop()
    rows = rows_of(tmp_path / "human_eve.csv")
    assert [(row["arena"], row["seed"]) for row in rows] == [(arena.name, "0"), (arena.name, "1")]
    assert all(row["steps"] == "40" for row in rows) and status["last"]["arena"] == arena.name
