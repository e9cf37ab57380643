"""Trust at the boundaries, in bulk: extreme values for every config key and arena field, fuzzed
arena files, configs and command lines (Hypothesis), SIGKILL at random moments, a million-step soak,
a real full disk and torn lines: each ends in a clear error or a valid result, never another
exception, and keeps the rows written before it."""

import csv
import json
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

pytest.importorskip("stable_baselines3", reason="needs the train extra")

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

SHORT = {"episode": {"max_steps": 15}}


def _yaml(tmp_path: Path, name: str, config: dict) -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(config))
    return path


def _eval(*args):
    return CliRunner().invoke(cli, ["eval", "--levels", "0", "--difficulty", "0", "-k", "1", *map(str, args)])


# --- bad inputs in bulk: each a clear error or a valid result, never another exception -------------
EXTREMES = [float("inf"), float("nan"), 1e308, "1e400", 2**63]
MORE_EXTREMES = EXTREMES + [-1e308, 10**30, -(10**30), float("-inf"), "0x10", 1e-320, "nan", "  7 ", True, None, [], {}]


def _config_sweep(values) -> int:
    tried = 0
    for key in load_config(None).flat():
        section, _, leaf = key.rpartition(".")
        for value in values:
            tried += 1
            try:
                load_config({section: {leaf: value}} if section else {leaf: value})
            except ConfigError as error:
                assert leaf in str(error), (key, value, str(error))
    return tried


def test_extreme_numbers_for_every_config_key_are_taken_or_refused_naming_the_key():
    assert _config_sweep(EXTREMES) >= 300


@pytest.mark.long
def test_more_extreme_values_for_every_config_key():
    assert _config_sweep(MORE_EXTREMES) >= 1000


def test_extreme_numbers_anywhere_in_an_arena_file_are_clear_errors(tmp_path):
    from aaai.task.arena import load_arena

    source = Path(__file__).parents[1] / "configs" / "arenas" / "l0_food_ahead.yaml"
    data = yaml.safe_load(source.read_text())

    def numbers(node, where=()):
        if isinstance(node, dict):
            for key, value in node.items():
                yield from numbers(value, where + (key,))
        elif isinstance(node, list):
            for index, value in enumerate(node):
                yield from numbers(value, where + (index,))
        elif isinstance(node, (int, float)) and not isinstance(node, bool):
            yield where

    tried = 0
    for where in list(numbers(data)):
        for value in [1e308, -1e308, 10**30, 2**63, float("inf"), float("nan"), 1e-320, -1.0, 0, "1e5"]:
            changed = yaml.safe_load(source.read_text())
            node = changed
            for part in where[:-1]:
                node = node[part]
            node[where[-1]] = value
            path = tmp_path / "extreme.yaml"
            path.write_text(yaml.safe_dump(changed))
            tried += 1
            try:
                load_arena(path, 0)
            except ConfigError as error:
                assert "extreme.yaml" in str(error)
    assert tried >= 100


# --- fuzzing: generated arena files, configs and command lines (Hypothesis) --------------------
# A fast, derandomised subset runs in make test; make test-long runs FUZZ_LONG examples of each
# surface (3 x 3,400 = 10,200). Every input must end cleanly: a result or a clear error, no other
# exception. Inputs that once failed are kept as @example()s.
from hypothesis import HealthCheck, example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from aaai.spec.kinds import OBJECT_KINDS  # noqa: E402

FUZZ_FAST, FUZZ_LONG = 40, 3400
_fuzz = dict(derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))
extreme = st.sampled_from([float("inf"), float("-inf"), float("nan"), 1e308, -1e308, 2**63, 10**30, 0, -1, 1e-320])
number = st.one_of(st.floats(-30, 30), st.integers(-30, 30), extreme)
junk = st.one_of(st.none(), st.booleans(), st.text(max_size=6), st.lists(st.integers(-3, 3), max_size=3), extreme)
triple = st.one_of(st.lists(number, min_size=3, max_size=3), junk)
objects = st.fixed_dictionaries(
    {"kind": st.one_of(st.sampled_from(OBJECT_KINDS), junk), "position": triple, "size": triple},
    optional={
        "shape": st.one_of(st.sampled_from(["box", "sphere", "cylinder"]), junk),
        "yaw": number,
        "mass": number,
        "colour": junk,
        "behaviour": st.one_of(
            junk,
            st.fixed_dictionaries(
                {"type": st.sampled_from(["random_walk", "sink", "slide", "door", "hinge", "other"])}
            ),
        ),
        "junk": junk,
    },
)
arenas = st.fixed_dictionaries(
    {
        "agent": st.one_of(st.fixed_dictionaries({"x": number, "y": number}, optional={"yaw": number}), junk),
        "objects": st.one_of(st.lists(objects, max_size=4), junk),
    },
    optional={
        "arena_walls": st.one_of(st.booleans(), junk),
        "arena_size": st.one_of(st.lists(number, min_size=2, max_size=2), junk),
        "time_limit": number,
        "tiles": junk,
        "holes": junk,
        "seed": number,
        "difficulty": number,
        "category": st.one_of(st.sampled_from(["food_contact", "L3", "nowhere"]), junk),
        "colours": junk,
        "extras": junk,
        "uniform": junk,
    },
)


def _arena_ends_cleanly(tmp_path: Path, data: dict, seed: int) -> None:
    from aaai.task.arena import load_arena

    path = tmp_path / "fuzzed.yaml"
    path.write_text(yaml.safe_dump(data))
    try:
        load_arena(path, seed)
    except ConfigError as error:
        assert "fuzzed.yaml" in str(error), str(error)


@settings(max_examples=FUZZ_FAST, **_fuzz)
@given(data=arenas, seed=st.integers(0, 3))
@example(data={"agent": {"x": 1e308, "y": 0}, "objects": [], "arena_walls": True}, seed=0)  # once a traceback
@example(
    data={
        "agent": {"x": 0, "y": 0},
        "arena_walls": True,
        "objects": [  # once accepted: exact overlap
            {"kind": "food_green", "position": [-9, -9, 0.5], "size": [1, 1, 1]}
        ]
        * 2,
    },
    seed=0,
)
def test_fuzzed_arena_files_end_cleanly(tmp_path_factory, data, seed):
    _arena_ends_cleanly(tmp_path_factory.mktemp("fuzz"), data, seed)


@pytest.mark.long
@settings(max_examples=FUZZ_LONG, **_fuzz)
@given(data=arenas, seed=st.integers(0, 3))
def test_fuzzed_arena_files_end_cleanly_long(tmp_path_factory, data, seed):
    _arena_ends_cleanly(tmp_path_factory.mktemp("fuzz"), data, seed)


def _config_keys():
    return sorted(load_config(None).flat())


configs = st.dictionaries(
    st.sampled_from(_config_keys() + ["agent.nothing", "nowhere"]),
    st.one_of(number, junk, st.sampled_from(["auto", "gait", "std", "0-3", "1e400"])),
    max_size=4,
)


def _config_ends_cleanly(flat: dict) -> None:
    tree: dict = {}
    for key, value in flat.items():
        section, _, leaf = key.rpartition(".")
        (tree.setdefault(section, {}) if section else tree)[leaf] = value
    try:
        load_config(tree)
    except ConfigError as error:
        assert any(key.rpartition(".")[2] in str(error) for key in flat), str(error)


@settings(max_examples=FUZZ_FAST, **_fuzz)
@given(configs)
def test_fuzzed_configs_end_cleanly(flat):
    _config_ends_cleanly(flat)


@pytest.mark.long
@settings(max_examples=FUZZ_LONG, **_fuzz)
@given(configs)
def test_fuzzed_configs_end_cleanly_long(flat):
    _config_ends_cleanly(flat)


small_text = st.one_of(
    st.sampled_from(["0", "1", "0-1", "1,0", "12", "13", "-1", "x", "", "0-", "1e3", "99999999999999999999"]),
    st.text(alphabet="0123456789-,x ", max_size=6),
)
OPTIONS = {
    "spec": {"-d": small_text, "-s": small_text, "--json": None, "--yaml": None},
    "seeds": {"--levels": small_text, "--difficulty": small_text, "-k": st.sampled_from(["1", "2", "0", "x"])},
    "validate": {
        "--levels": small_text,
        "--difficulty": small_text,
        "--seeds": st.sampled_from(["1", "0", "x"]),
        "--first-seed": small_text,
    },
    "run": {
        "--levels": small_text,
        "--difficulty": small_text,
        "--episodes": st.sampled_from(["1", "0", "-3", "x"]),
        "--seed": small_text,
        "--policy": st.sampled_from(["random", "reference", "json:nothing", "nothing.zip", "x"]),
        "--max-steps": st.sampled_from(["10", "0", "-5", "1e9", "x"]),
        "--camera": None,
        "--no-rays": None,
    },
    "eval": {
        "--levels": small_text,
        "--difficulty": small_text,
        "-k": st.sampled_from(["1", "0", "x"]),
        "--seeds": st.sampled_from(["reserved", "train", "1,2", "x", "", "-1", "1,99999999999999999999"]),
        "--policy": st.sampled_from(["random", "json:nothing", "nothing.zip", "x", "reference"]),
        "--backend": st.sampled_from(["local", "cluster"]),
        "--trust-model": None,
    },
}


@st.composite
def command_lines(draw):
    command = draw(st.sampled_from(sorted(OPTIONS) + ["levels", "nothing"]))
    args = [command]
    if command == "spec":
        args.append(draw(small_text))
    for option, values in draw(
        st.lists(
            st.sampled_from(sorted(OPTIONS.get(command, {"--x": None}).items())),
            max_size=4,
            unique_by=lambda item: item[0],
        )
    ):
        args += [option] if values is None else [option, draw(values)]
    if draw(st.booleans()):
        args.append(draw(st.sampled_from(["--nothing", "extra", "--levels"])))
    return args


def _command_ends_cleanly(tmp_path: Path, args: list[str]) -> None:
    if args[0] in ("run", "eval") and "--max-steps" not in args:  # short episodes: the run is not the point
        args = args + ["--config", str(_yaml(tmp_path, "short.yaml", {"episode": {"max_steps": 10}}))]
    if args[0] == "eval":
        args = args + ["--out", str(tmp_path / "board.csv"), "--difficulty", "0"]
    if args[0] in ("run", "validate", "eval") and "--levels" not in args:
        args = args + ["--levels", "0"]
    if args[0] == "validate" and "--seeds" not in args:  # not 100 seeds x 11 difficulties
        args = args + ["--seeds", "1"]
    result = CliRunner().invoke(cli, args)
    assert result.exception is None or isinstance(result.exception, SystemExit), (args, result.output)
    assert "Traceback" not in result.output


@settings(max_examples=FUZZ_FAST, **_fuzz)
@given(args=command_lines())
@example(args=["validate", "--first-seed", "99999999999999999999"])  # once a traceback (a seed past the limit)
@example(args=["run", "--seed", "99999999999999999999"])  # once a traceback (found by the long run)
@example(args=["eval", "--seeds", "-1"])  # once a traceback from Gymnasium
def test_fuzzed_command_lines_end_cleanly(tmp_path_factory, args):
    _command_ends_cleanly(tmp_path_factory.mktemp("cli"), args)


@pytest.mark.long
@settings(max_examples=FUZZ_LONG, **_fuzz)
@given(args=command_lines())
def test_fuzzed_command_lines_end_cleanly_long(tmp_path_factory, args):
    _command_ends_cleanly(tmp_path_factory.mktemp("cli"), args)


# --- faults: SIGKILL at seeded random moments -----------------------------------------------
def _rows_without_timing(path: Path) -> list[dict]:
    with open(path) as handle:
        return [{k: v for k, v in row.items() if k != "wall_seconds"} for row in csv.DictReader(handle)]


@pytest.mark.long
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_an_eval_killed_at_a_random_moment_resumes_to_the_uninterrupted_scoreboard(tmp_path, seed):
    import os
    import random
    import signal
    import subprocess
    import sys
    import time

    config = _yaml(tmp_path, "short.yaml", {"episode": {"max_steps": 40}})
    command = [
        sys.executable,
        "-m",
        "aaai_cli.main",
        "eval",
        "--policy",
        "reference",
        "--levels",
        "0-1",
        "--difficulty",
        "0-1",
        "-k",
        "2",
        "--config",
        str(config),
    ]
    whole = tmp_path / "whole.csv"
    subprocess.run(command + ["--out", str(whole)], check=True, capture_output=True)
    rng = random.Random(seed)
    killed = tmp_path / "killed.csv"
    rows_before_kill = rng.randint(0, 6)
    process = subprocess.Popen(command + ["--out", str(killed)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if killed.exists() and len(killed.read_text().splitlines()) - 1 >= rows_before_kill:
            time.sleep(rng.uniform(0.0, 0.3))  # somewhere inside the next episode (or its write)
            break
        time.sleep(0.01)
    if process.poll() is None:
        os.kill(process.pid, signal.SIGKILL)
    process.wait()
    subprocess.run(command + ["--out", str(killed)], check=True, capture_output=True)
    assert _rows_without_timing(killed) == _rows_without_timing(whole)


# --- soak: a million steps over every level and kind, with resets ------------------------------
@pytest.mark.long
def test_a_million_steps_keep_memory_and_connections_bounded(tmp_path):
    """bench/soak.py in a process of its own, so that what it measures is what it made, whichever
    tests ran before it in this one (their connections and memory): one JSON line per 25,000 steps in
    AAAI_SOAK_OUT (default: a temporary file), so that a soak stopped part-way resumes where it was
    when the test is run again with the same file."""
    import os
    import subprocess
    import sys

    out = Path(os.environ.get("AAAI_SOAK_OUT", tmp_path / "soak.jsonl"))
    steps = os.environ.get("AAAI_SOAK_STEPS", "1000000")
    script = Path(__file__).parents[1] / "bench" / "soak.py"
    done = subprocess.run(
        [sys.executable, str(script), "--steps", steps, "--out", str(out)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    print(result)
    assert result["episodes"] >= result["steps"] // 1000 and result["connections"] == [1]
    assert result["levels"] == sorted(soak_script_levels())
    assert result["rss_max_mb"] - result["rss_after_warm_up_mb"] < 50
    assert result.get("connections_after_close", 0) == 0


def soak_script_levels() -> list[int]:
    from aaai.levels import level_ids

    return list(level_ids())


@pytest.mark.long
def test_a_real_full_disk_keeps_the_rows_and_a_rerun_after_freeing_space_completes(tmp_path):
    """On a 64 KiB tmpfs filled to three free pages (needs the right to mount, as root in CI's container)."""
    import subprocess
    import sys

    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(disk)], capture_output=True).returncode:
        pytest.skip("cannot mount a small filesystem here")
    try:
        filler = disk / "filler"
        with open(
            filler, "wb", buffering=0
        ) as handle:  # fill it, then give back three pages: the lock, the record, rows
            try:
                while True:
                    handle.write(b"x" * 4096)
            except OSError:
                pass
        with open(filler, "r+b") as handle:
            handle.truncate(max(0, filler.stat().st_size - 3 * 4096))
        config = _yaml(tmp_path, "short.yaml", {"episode": {"max_steps": 10}})
        out = disk / "board.csv"
        command = [
            sys.executable,
            "-m",
            "aaai_cli.main",
            "eval",
            "--policy",
            "random",
            "--levels",
            "0",
            "--difficulty",
            "0-1",
            "-k",
            "60",
            "--config",
            str(config),
            "--out",
            str(out),
        ]
        full = subprocess.run(command, capture_output=True, text=True)
        message = " ".join((full.stdout + full.stderr).split())
        assert full.returncode != 0 and "Traceback" not in message, message
        assert str(out) in message and "No space left on device" in message
        with open(out) as handle:
            kept = list(csv.DictReader(handle))
        assert 10 <= len(kept) < 120  # about a page of rows
        filler.unlink()
        subprocess.run(command, check=True, capture_output=True)
        with open(out) as handle:
            rows = list(csv.DictReader(handle))
        assert len(rows) == 120 and rows[: len(kept) - 1] == kept[:-1]  # (the last kept may have been torn)
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_line_torn_mid_file_is_cut_and_played_again(tmp_path):
    config = _yaml(tmp_path, "short.yaml", SHORT)
    out = tmp_path / "board.csv"
    assert _eval("--policy", "random", "--config", config, "-k", "4", "--out", out).exit_code == 0
    whole = _rows_without_timing(out)
    lines = out.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:2] + [lines[2][:20] + lines[3]] + lines[4:]))  # a write cut short, then appended to
    resumed = _eval("--policy", "random", "--config", config, "-k", "4", "--out", out)
    assert resumed.exit_code == 0, resumed.output
    assert sorted(map(str, _rows_without_timing(out))) == sorted(map(str, whole))
