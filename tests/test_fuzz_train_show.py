"""Fuzzed `aaai train` and `aaai show` command lines (Hypothesis, derandomised): each ends in a
result or a clear error (no traceback), within 30 s, and corrupts no file: a run folder it was
pointed at still reads whole, a picture or video already in place is still whole.

A fast budget runs in make test; make test-long runs FUZZ_LONG of each. Inputs that once failed
are kept as @example()s.
"""

from __future__ import annotations

import csv
import json
import shutil
import signal
import time
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aaai_cli.main import cli

FUZZ_FAST, FUZZ_LONG = 25, 1000
HANG_SECONDS = 30
_fuzz = dict(derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))


class Hang(BaseException):
    """Raised by the alarm: not an Exception, so that click's test runner does not swallow it."""


def _invoke(args: list[str]):
    def ring(*_):
        raise Hang(f"aaai {' '.join(args)} ran over {HANG_SECONDS} s")

    previous = signal.signal(signal.SIGALRM, ring)
    signal.alarm(HANG_SECONDS)
    try:
        started = time.monotonic()
        result = CliRunner().invoke(cli, args)
        return result, time.monotonic() - started
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _ends_cleanly(args: list[str], result) -> None:
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        args,
        result.output,
        repr(result.exception),
    )
    assert "Traceback" not in result.output, (args, result.output)
    if result.exit_code not in (0, None):
        assert result.output.strip(), (args, "failed without a message")


# --- train -------------------------------------------------------------------------------------
small_text = st.one_of(
    st.sampled_from(["0", "1", "0-1", "1,0", "12", "13", "-1", "x", "", "0-", "1e3", "99999999999999999999"]),
    st.text(alphabet="0123456789-,x ", max_size=6),
)
TRAIN = {
    "--levels": small_text,
    "--difficulty": small_text,
    "--steps": st.sampled_from(["32", "64", "0", "-5", "x", "1e3", "99999999999999999999", ""]),
    "--envs": st.sampled_from(["1", "0", "-1", "x", "100000", "257", "1.5"]),
    "--seed": st.sampled_from(["0", "-1", "x", "99999999999999999999", "4294967295", "4294967296"]),
    "--agent": st.sampled_from(["random", "ppo", "x", ""]),
    "--camera": None,
    "--no-camera": None,
    "--rays": None,
    "--no-rays": None,
    "--camera-resolution": st.sampled_from(["8", "0", "-4", "x", "100000", "513", "7"]),
    "--random": None,
    "--curriculum": None,
    "--sampler": st.sampled_from(["paper", "uniform", "plr", "x"]),
    "--progress-every": st.sampled_from(["0.1", "0", "nan", "inf", "x"]),
    "--action-mode": st.sampled_from(["rotation", "gait", "x"]),
    "--backend": st.sampled_from(["sb3", "cluster"]),
    "--init-from": st.sampled_from(["RUN", "nothing.zip", "CONFIG", ""]),
    "--resume": st.sampled_from(["RUN", "nothing", "CONFIG", ""]),
    "--config": st.sampled_from(["CONFIG", "BROKEN", "nothing.yaml"]),
    "--trust-model": None,
    "--teacher": st.sampled_from(["reference", "x"]),
}


@st.composite
def train_lines(draw):
    args = ["train"]
    for option, values in draw(
        st.lists(st.sampled_from(sorted(TRAIN.items())), max_size=4, unique_by=lambda item: item[0])
    ):
        args += [option] if values is None else [option, draw(values)]
    if draw(st.booleans()):
        args.append(draw(st.sampled_from(["--nothing", "extra", "--steps"])))
    return args


@pytest.fixture(scope="module")
def train_place(tmp_path_factory):
    """A short config, a broken one, and a finished random-agent run to resume or start from."""
    folder = tmp_path_factory.mktemp("train_fuzz")
    config = folder / "short.yaml"
    config.write_text(
        yaml.safe_dump(
            {
                "episode": {"max_steps": 10},
                "train": {
                    "checkpoint_every": 64,
                    "heatmap_every": 100000,
                    "n_steps": 16,
                    "batch_size": 16,
                    "n_epochs": 1,
                    "net_width": 8,
                    "num_envs": 1,
                    "dagger_iterations": 1,
                    "dagger_episodes": 2,
                    "dagger_epochs": 1,
                },
            }
        )
    )
    (folder / "broken.yaml").write_text("episode: {max_steps: [\n")
    run = folder / "run"
    result = CliRunner().invoke(
        cli, ["train", "--agent", "random", "--steps", "32", "--envs", "1", "--config", str(config), "--run", str(run)]
    )
    assert result.exit_code == 0, result.output
    return folder


def _run_reads_whole(run: Path) -> None:
    """A run folder (whatever a command did to it) still reads: its config, its states, its log."""
    if not run.exists():
        return
    if (run / "config.yaml").exists():
        assert isinstance(yaml.safe_load((run / "config.yaml").read_text()), dict)
    for state in run.glob("**/state.json"):
        json.loads(state.read_text())
    if (run / "episodes.csv").exists():
        with open(run / "episodes.csv", newline="") as handle:
            rows = list(csv.DictReader(handle))
        assert all(None not in row and None not in row.values() for row in rows), "a torn episode row"


def _train_ends_cleanly(place: Path, args: list[str]) -> None:
    work = place / "work"
    shutil.rmtree(work, ignore_errors=True)
    shutil.copytree(place / "run", work / "run")  # each example gets the finished run afresh
    names = {"RUN": str(work / "run"), "CONFIG": str(place / "short.yaml"), "BROKEN": str(place / "broken.yaml")}
    args = [names.get(arg, arg) for arg in args]
    resuming = "--resume" in args and args[args.index("--resume") + 1 :][:1] == [names["RUN"]]
    if "--config" not in args and not resuming:  # not the default config's long run (or DAgger's 8 x 143 episodes)
        args += ["--config", names["CONFIG"]]
    if "--steps" not in args:
        args += ["--steps", "32"]
    if "--envs" not in args:
        args += ["--envs", "1"]
    if "--run" not in args and not resuming:
        args += ["--run", str(work / "new")]
    if "--progress-every" not in args:
        args += ["--progress-every", "1000"]
    result, _ = _invoke(args)
    _ends_cleanly(args, result)
    _run_reads_whole(work / "run")
    _run_reads_whole(work / "new")


@settings(max_examples=FUZZ_FAST, **_fuzz)
@given(args=train_lines())
def test_fuzzed_train_command_lines_end_cleanly(train_place, args):
    _train_ends_cleanly(train_place, args)


@pytest.mark.long
@settings(max_examples=FUZZ_LONG, **_fuzz)
@given(args=train_lines())
def test_fuzzed_train_command_lines_end_cleanly_long(train_place, args):
    _train_ends_cleanly(train_place, args)


# --- show --------------------------------------------------------------------------------------
SHOW = {
    "-d": small_text,
    "-s": small_text,
    "--arena": st.sampled_from(["ARENA", "BROKEN", "nothing.yaml", ""]),
    "-o": st.sampled_from(["PNG", "out.jpg", "out.txt", "DIR", ""]),
    "--video": st.sampled_from(["VIDEO", "out.avi", "out.gif", "DIR", ""]),
    "--policy": st.sampled_from(["random", "reference", "gait", "json:nothing", "nothing.zip", "x", "os:system"]),
    "--steps": st.sampled_from(["5", "1", "0", "-1", "x", "99999999999999999999", "10001"]),
    "--fps": st.sampled_from(["25", "1", "0", "501", "x"]),
    "--size": st.sampled_from(["200", "199", "4001", "x", "nan"]),
    "--config": st.sampled_from(["CONFIG", "BROKEN", "nothing.yaml"]),
    "--action-mode": st.sampled_from(["rotation", "gait", "x"]),
    "--trust-model": None,
    "--replay": st.sampled_from(["BROKEN", "nothing.json", "PNG"]),
}


@st.composite
def show_lines(draw):
    args = ["show"]
    if draw(st.booleans()):
        args.append(draw(st.one_of(small_text, st.sampled_from(["L1", "L2b", "food_contact", "L99", "nothing"]))))
    for option, values in draw(
        st.lists(st.sampled_from(sorted(SHOW.items())), max_size=4, unique_by=lambda item: item[0])
    ):
        args += [option] if values is None else [option, draw(values)]
    if draw(st.booleans()):
        args.append(draw(st.sampled_from(["--nothing", "extra", "--steps"])))
    return args


@pytest.fixture(scope="module")
def show_place(tmp_path_factory):
    """A short config, a broken YAML, an arena file, and a picture and a video already in place."""
    folder = tmp_path_factory.mktemp("show_fuzz")
    (folder / "short.yaml").write_text(yaml.safe_dump({"episode": {"max_steps": 10}}))
    (folder / "broken.yaml").write_text("agent: {x: [\n")
    (folder / "arena.yaml").write_text(
        yaml.safe_dump(
            {
                "agent": {"x": 0, "y": 0},
                "arena_walls": True,
                "objects": [{"kind": "food_green", "position": [3, 3, 0.5], "size": [1, 1, 1]}],
            }
        )
    )
    (folder / "dir").mkdir()
    for extra in (["-o", str(folder / "keep.png")], ["--video", str(folder / "keep.mp4"), "--steps", "5"]):
        result = CliRunner().invoke(cli, ["show", "0", "--size", "200", *extra])
        assert result.exit_code == 0, result.output
    return folder


def _picture_whole(path: Path) -> bool:
    import cv2

    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and cv2.imread(str(path)) is not None


def _video_whole(path: Path) -> bool:
    import cv2

    capture = cv2.VideoCapture(str(path))
    try:
        return capture.isOpened() and int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) >= 1
    finally:
        capture.release()


def _show_ends_cleanly(place: Path, args: list[str]) -> None:
    work = place / "work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    shutil.copy(place / "keep.png", work / "keep.png")
    shutil.copy(place / "keep.mp4", work / "keep.mp4")
    names = {
        "ARENA": str(place / "arena.yaml"),
        "BROKEN": str(place / "broken.yaml"),
        "CONFIG": str(place / "short.yaml"),
        "PNG": str(work / "keep.png"),
        "VIDEO": str(work / "keep.mp4"),
        "DIR": str(place / "dir"),
        "out.jpg": str(work / "out.jpg"),
        "out.txt": str(work / "out.txt"),
        "out.avi": str(work / "out.avi"),
        "out.gif": str(work / "out.gif"),
    }
    args = [names.get(arg, arg) for arg in args]
    if "--config" not in args:
        args += ["--config", names["CONFIG"]]
    if "--size" not in args:
        args += ["--size", "200"]
    if "-o" not in args and "--video" not in args:
        args += ["-o", str(work / "default.png")]
    if "--video" in args and "--steps" not in args:
        args += ["--steps", "20"]
    result, _ = _invoke(args)
    _ends_cleanly(args, result)
    assert _picture_whole(work / "keep.png"), (args, "the picture in place was damaged")
    assert _video_whole(work / "keep.mp4"), (args, "the video in place was damaged")
    for leftover in work.iterdir():  # anything written is whole; nothing half-written is left behind
        assert not leftover.name.startswith("."), (args, f"a temporary file left behind: {leftover.name}")
        if leftover.suffix == ".png":
            assert _picture_whole(leftover), (args, leftover.name)
    assert not any((place / "dir").iterdir()), (args, "something written inside a folder given as a file")


@settings(max_examples=FUZZ_FAST, **_fuzz)
@given(args=show_lines())
def test_fuzzed_show_command_lines_end_cleanly(show_place, args):
    _show_ends_cleanly(show_place, args)


@pytest.mark.long
@settings(max_examples=FUZZ_LONG, **_fuzz)
@given(args=show_lines())
def test_fuzzed_show_command_lines_end_cleanly_long(show_place, args):
    _show_ends_cleanly(show_place, args)


# --- inputs that once failed -------------------------------------------------------------------
@pytest.mark.parametrize("command", [["train"], ["eval"], ["experiment", "curricula"]])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_progress_every_that_is_not_a_finite_number_is_refused(command, value, tmp_path, monkeypatch):
    """Once taken: FloatRange(0.1) lets NaN and infinity through (NaN compares false with its bounds)."""
    monkeypatch.chdir(tmp_path)  # taken by mistake, the command writes its default outputs here
    result = CliRunner().invoke(cli, [*command, "--progress-every", value])
    assert result.exit_code == 2 and "--progress-every" in result.output, result.output
