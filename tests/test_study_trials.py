"""A study's trials as a participant plays them: the path the body's trunk travels, in metres,
recorded with each trial."""

from __future__ import annotations

import json
import math
import os
from contextlib import ExitStack

import pytest
from click.testing import CliRunner

from aaai.levels import generate
from aaai.study.participant import Odometer
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
time_limit: 1.2
camera_resolution: 16
"""


def test_the_odometer_sums_the_trunks_horizontal_steps_in_metres():
    odometer = Odometer()
    for x, y in [(0.0, 0.0), (3.0, 4.0), (3.0, 4.0), (6.0, 8.0)]:
        odometer.add(x, y)
    assert odometer.metres == 10.0  # 5 + 0 + 5 (1 world unit = 1 m)
    odometer.reset()
    odometer.add(100.0, 100.0)
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


def test_a_trial_records_the_path_the_trunk_walked_in_metres(served):
    store, port, token, _ = served
    with ExitStack() as stack:
        page = Client(stack, port, token)
        page.send({"type": "consent"})
        page.next("consented")
        page.send({"type": "start"})
        page.pump(ready)
        page.send({"type": "key", "key": "ArrowUp", "down": True})  # starts the trial and walks on
        page.pump(lambda s: s["phase"] == "ready" and s["progress"]["done"] == 1)
    first = store.trials("P001")[0]
    replay = json.loads(first["replay"])
    start = generate(0, 0, 1).agent
    straight = math.hypot(replay["final_pose"]["x"] - start.x, replay["final_pose"]["y"] - start.y)
    assert straight > 0.5  # it walked
    assert straight <= first["path_m"] < 1.5 * straight  # at least the straight line; a trot sways a little
