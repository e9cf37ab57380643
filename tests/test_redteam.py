"""Inputs the red-team run (bench/redteam.py) found to end in a traceback, a hang or a write
outside the output: each is now one clear refusal (ConfigError or an OSError naming the file)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from aaai.config import ConfigError
from aaai.files import hold
from aaai.scoring import replays
from aaai.scoring.evaluation import check_record, scored_episodes
from aaai.scoring.runs import check_writable


def _replay(**changes) -> dict:
    data = {
        "format": replays.FORMAT,
        "version": replays.VERSION,
        "policy": "random",
        "level": 0,
        "level_name": "food_contact",
        "difficulty": 0,
        "seed": 1,
        "arena": None,
        "spec_digest": "0" * 64,
        "config": {},
        "config_digest": replays.config_digest({}),
        "steps": 20,
        "return": 0.0,
        "final_pose": {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0},
        "end": "time",
        "actions": [[20, [0.0] * 8]],
    }
    return {**data, **changes}


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "r.json"
    path.write_text(text, errors="surrogatepass")
    return path


def test_a_well_formed_replay_loads(tmp_path):
    assert replays.load_replay(_write(tmp_path, json.dumps(_replay())))["steps"] == 20


@pytest.mark.parametrize(
    "text, words",
    [
        ("[" * 200_000 + "]" * 200_000, "nests too deeply"),
        (json.dumps(_replay(steps=10**9, actions=[[10**9, [0.0] * 8]])), "at most 10,000"),
        (json.dumps(_replay(spec_digest=12)), "'spec_digest': got 12; allowed: text"),
        (json.dumps(_replay(end={"x": 1})), "'end'"),
        (json.dumps(_replay(policy="\ud800")), "lone surrogate"),
    ],
    ids=["deep", "billion-steps", "digest-number", "end-object", "surrogate"],
)
def test_a_hostile_replay_is_refused_in_one_line(tmp_path, text, words):
    with pytest.raises(ConfigError, match=words.replace("(", r"\(")):
        replays.load_replay(_write(tmp_path, text))


def test_a_replay_whose_actions_do_not_fit_its_body_is_refused_before_it_runs():
    replay = _replay(actions=[[20, [0.0] * 3]])
    with pytest.raises(ConfigError, match="an action has 3 numbers; allowed: 8"):
        replays.make_env(replay)


def test_a_pipe_or_a_device_as_out_is_refused_not_read(tmp_path):
    os.mkfifo(tmp_path / "s.csv")  # reading it would wait for a writer for ever
    for path in (tmp_path / "s.csv", Path("/dev/full")):  # /dev/full: reads never end
        with pytest.raises(ConfigError, match="a device or a pipe"):
            check_writable(path, "--out")


@pytest.mark.parametrize(
    "content", [bytes(range(256)) * 8, "a,b\n".encode("utf-16"), b"level\nf\xe9od\n"], ids=["binary", "utf16", "latin1"]
)
def test_a_scoreboard_that_is_not_utf8_is_refused_naming_it(tmp_path, content):
    path = tmp_path / "s.csv"
    path.write_bytes(content)
    with pytest.raises(ConfigError):  # the record check runs first in eval: it reads the bytes as bytes
        check_record(path, {"policy": "random"})
    with pytest.raises(ConfigError, match="is not a scoreboard: byte"):
        scored_episodes(path)


def test_a_lock_file_that_is_a_link_elsewhere_is_never_written_through(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (tmp_path / "run").mkdir()
    os.symlink(victim, tmp_path / "run" / ".lock")
    with pytest.raises(OSError, match=".lock"):
        hold(tmp_path / "run" / ".lock", lambda pid: "in use")
    assert victim.read_text() == "precious\n"
