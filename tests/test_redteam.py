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


def test_a_model_zip_with_an_encrypted_member_is_refused_naming_it(tmp_path):
    import zipfile

    from aaai.scoring.runs import model_problem

    path = tmp_path / "m.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", "{}")
        archive.writestr("policy.pth", b"x")
    raw = bytearray(path.read_bytes())
    for signature, offset in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):  # set the "encrypted" flag bit
        at = raw.find(signature)
        while at >= 0:
            raw[at + offset] |= 1
            at = raw.find(signature, at + 4)
    path.write_bytes(bytes(raw))
    assert (
        model_problem(path)
        == "m.zip has an encrypted member ('data'); allowed: members as stable-baselines3 writes them"
    )


def _arena(tmp_path, body: str) -> Path:
    path = tmp_path / "a.yaml"
    path.write_text(
        "agent: {x: 0, y: -18, yaw: 1.5707963267948966}\n" + body + "objects:\n"
        "  - {kind: food_green, position: [0, 5, 1.5], size: [3, 3, 3]}\n"
    )
    return path


@pytest.mark.parametrize(
    "body",
    ["heightfield:\n  - [0, 1, 2]\n  - [0]\n", "heightfield:\n  - [0, 1]\n"],
    ids=["ragged", "one-row"],
)
def test_a_heightfield_that_is_not_a_grid_of_heights_is_refused_by_the_arena_check(tmp_path, body):
    from aaai.task.arena import load_arena

    with pytest.raises(ConfigError, match="heightfield"):
        load_arena(_arena(tmp_path, body))


def test_a_blackout_shorter_than_a_step_is_dark_throughout_not_a_division_by_zero():
    from aaai.sim.sensors import Blackout
    from aaai.spec import Blackout as Schedule

    blackout = Blackout(Schedule(1e-300, 1e-300), control_dt=0.02)
    assert [blackout.dark(step) for step in range(3)] == [True, True, True]
    assert [Blackout(Schedule(0.04, 0.02), 0.02).dark(step) for step in range(4)] == [False, False, True, False]


def test_init_from_a_pipe_or_a_device_is_refused_not_read(tmp_path):
    from aaai.config import load_config
    from aaai.train.training import check_init_from

    os.mkfifo(tmp_path / "m.zip")
    for source in (tmp_path / "m.zip", "/dev/zero"):
        config = load_config(train={"agent": "ppo", "init_from": str(source)})
        with pytest.raises(ConfigError, match="a device or a pipe"):
            check_init_from(config)


@pytest.mark.parametrize(
    "form", ["{uniform: [-1.0e+308, 1.0e+308]}", "{integers: [-1.0e+30, 1.0e+30]}"], ids=["uniform", "integers"]
)
def test_a_random_form_over_a_span_numpy_cannot_draw_is_refused_by_line(tmp_path, form):
    from aaai.task.arena import load_arena

    path = tmp_path / "a.yaml"
    path.write_text(
        "agent: {x: 0, y: -18}\nobjects:\n  - {kind: food_green, position: [" + form + ", 5, 1.5], size: [3, 3, 3]}\n"
    )
    with pytest.raises(ConfigError, match="line 3.*allowed: \\[low, high\\]"):
        load_arena(path)


SCOREBOARD_HEADER = (
    "level,level_name,difficulty,seed,return,max_reward,ratio,outcome,steps,max_steps,food_eaten,wall_hits,fell,"
    "arena,wall_seconds\n"
)


@pytest.mark.parametrize(
    "row, words",
    [
        ("," * 14 + "\n", "row 2: level '' is not a number"),
        ("99,x,0,1,-0.5,3.5,-0.1,failed,20,20,0,0,False,,0.1\n", "row 2: level '99' does not exist"),
        ("0,food_contact,0,1,x,3.5,-0.1,failed,20,20,0,0,False,,0.1\n", "row 2: return 'x' is not a number"),
        ("0," + "9" * 200_000 + "\n", "is not a scoreboard .field larger"),
    ],
    ids=["empty-row", "level-99", "return-text", "long-field"],
)
def test_a_scoreboard_row_an_eval_never_writes_is_refused_naming_its_row(tmp_path, row, words):
    path = tmp_path / "s.csv"
    path.write_text(SCOREBOARD_HEADER + row)
    with pytest.raises(ConfigError, match=words):
        scored_episodes(path)


def test_resume_refuses_an_episode_log_that_is_a_pipe_and_cuts_bytes_that_are_not_text(tmp_path):
    from aaai.scoring.runs import EPISODE_COLUMNS, RunFolder

    run = RunFolder(tmp_path)
    os.mkfifo(run.episodes_path)
    with pytest.raises(ConfigError, match="is not a regular file"):
        run.trim_episodes(0)
    run.episodes_path.unlink()
    run.episodes_path.write_bytes(bytes(range(256)) * 4)
    run.trim_episodes(0)
    assert run.episodes_path.read_text().splitlines() == [",".join(EPISODE_COLUMNS)]


def test_a_checkpoint_state_nested_too_deep_or_a_pipe_is_skipped_not_a_crash(tmp_path):
    from aaai.scoring.runs import RunFolder, run_backend

    run = RunFolder(tmp_path)
    (tmp_path / "final").mkdir()
    (tmp_path / "final" / "state.json").write_text("[" * 100_000)
    assert run.unreadable(tmp_path / "final", needs_model=False) == "state.json nests too deeply"
    assert run.saved() == [tmp_path / "final"]
    assert run_backend(tmp_path) == "sb3"  # what --resume asks first
    (tmp_path / "final" / "state.json").unlink()
    os.mkfifo(tmp_path / "final" / "state.json")
    assert "not a regular file" in run.unreadable(tmp_path / "final", needs_model=False)


def test_a_seed_key_file_that_is_not_text_is_refused_naming_it(tmp_path):
    from aaai.levels.seeds import read_seed_key

    path = tmp_path / "k.key"
    path.write_bytes(bytes(range(256)))
    with pytest.raises(ValueError, match="'.*k.key' is not text .byte 128"):
        read_seed_key(path)


def test_a_scoreboard_of_blank_lines_starts_afresh_so_its_rows_get_a_header(tmp_path):
    from aaai.scoring.evaluation import COLUMNS, Scoreboard

    path = tmp_path / "s.csv"
    path.write_text("\n\n")
    assert scored_episodes(path) == []
    with Scoreboard(path, {"policy": "random"}, COLUMNS, [], None) as board:
        board.append({column: "0" for column in COLUMNS})
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)


def test_the_red_team_registers_the_attacks_its_csv_records_in_order(monkeypatch):
    """bench/redteam.csv names each attack (id and group) that `python bench/redteam.py` runs, in its order."""
    import csv

    bench = Path(__file__).resolve().parent.parent / "bench"
    monkeypatch.syspath_prepend(str(bench))
    from redteam_attacks import register

    with open(bench / "redteam.csv", newline="") as handle:
        recorded = [(row["id"], row["group"]) for row in csv.DictReader(handle)]
    assert [(a.id, a.group) for a in register()] == recorded
    assert len(recorded) == 398
