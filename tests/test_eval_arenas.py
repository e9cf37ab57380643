"""aaai eval --arenas: the scoreboard's record keeps each arena file's SHA-256, and resuming it after a
file has changed is refused, naming the file and both hashes; an older record without them resumes,
with a warning."""

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from aaai.files import file_sha256
from aaai_cli.main import cli

ARENAS = Path(__file__).resolve().parents[1] / "configs" / "arenas"
FILES = ("l0_food_ahead.yaml", "l0_food_behind.yaml")


@pytest.fixture
def battery(tmp_path):
    """Two shipped arena files in a folder of their own, a 10-step config, and the eval's arguments."""
    folder = tmp_path / "battery"
    folder.mkdir()
    for name in FILES:
        shutil.copy(ARENAS / name, folder / name)
    config = tmp_path / "short.yaml"
    config.write_text("episode:\n  max_steps: 10\n")
    board = tmp_path / "board.csv"
    args = ["eval", "--arenas", str(folder), "--policy", "random", "-k", "1", "--config", str(config)]
    return folder, board, [*args, "--out", str(board)]


def interrupted(board: Path) -> None:
    """The scoreboard as an eval stopped after its first episode leaves it."""
    board.write_text("".join(board.read_text().splitlines(keepends=True)[:2]))


def test_the_record_keeps_each_arena_files_sha256(battery):
    folder, board, args = battery
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    record = json.loads(board.with_name("board_scored_with.json").read_text())
    assert record["arena_sha256"] == {name: file_sha256(folder / name) for name in FILES}
    assert record["arenas"] == str(folder)


def test_resuming_after_an_arena_file_has_changed_is_refused(battery):
    folder, board, args = battery
    assert CliRunner().invoke(cli, args).exit_code == 0
    interrupted(board)
    kept = board.read_text()
    changed = folder / FILES[1]
    recorded = file_sha256(changed)
    changed.write_text(changed.read_text() + "# edited\n")
    refused = CliRunner().invoke(cli, args)
    assert refused.exit_code == 2 and "Traceback" not in refused.output, refused.output
    assert f"{str(changed)!r} is not the file {str(board)!r} was scored on" in refused.output
    assert f"SHA-256 {recorded} recorded, {file_sha256(changed)} now" in refused.output
    assert "score into a new --out" in refused.output
    assert board.read_text() == kept  # nothing played
    elsewhere = CliRunner().invoke(cli, [*args[:-1], str(board.with_name("new.csv"))])
    assert elsewhere.exit_code == 0, elsewhere.output


def test_an_older_record_without_hashes_resumes_with_a_warning(battery):
    folder, board, args = battery
    assert CliRunner().invoke(cli, args).exit_code == 0
    interrupted(board)
    path = board.with_name("board_scored_with.json")
    record = json.loads(path.read_text())
    del record["arena_sha256"]
    path.write_text(json.dumps(record))
    resumed = CliRunner().invoke(cli, args)
    assert resumed.exit_code == 0, resumed.output
    assert "records no SHA-256 of its arena files" in resumed.output
    assert "a file changed since its rows were scored cannot be detected" in resumed.output
    assert board.read_text().count("\n") == 3  # the header and both episodes
    assert "arena_sha256" not in json.loads(path.read_text())  # its rows were not checked: it claims no hashes


def test_more_seeds_continue_the_scoreboard_also_one_whose_record_names_its_first_seeds(battery):
    folder, board, args = battery
    assert CliRunner().invoke(cli, args).exit_code == 0
    path = board.with_name("board_scored_with.json")
    record = json.loads(path.read_text())
    record["seeds"] = "0-0"  # as a scoreboard of arena files recorded its first call's seeds before
    path.write_text(json.dumps(record))
    more = [*args]
    more[more.index("-k") + 1] = "2"
    resumed = CliRunner().invoke(cli, more)
    assert resumed.exit_code == 0, resumed.output
    rows = board.read_text().splitlines()[1:]
    seeds = sorted((row.split(",")[3], row.split(",")[-2]) for row in rows)
    assert seeds == [("0", FILES[0]), ("0", FILES[1]), ("1", FILES[0]), ("1", FILES[1])]
    other = CliRunner().invoke(cli, [*more[:-1], str(board.with_name("fresh.csv"))])
    assert other.exit_code == 0 and json.loads(board.with_name("fresh_scored_with.json").read_text())["seeds"] == "list"


def test_a_battery_that_grows_continues_its_scoreboard(battery, tmp_path):
    # a new import makes one more file valid, in another folder: only its episode is played, and the
    # record names both files and the new folder
    folder, board, args = battery
    only_first = tmp_path / "first"
    only_first.mkdir()
    shutil.copy(folder / FILES[0], only_first / FILES[0])
    first = [str(only_first) if a == str(folder) else a for a in args]
    assert CliRunner().invoke(cli, first).exit_code == 0
    before = board.read_text()
    grown = CliRunner().invoke(cli, args)
    assert grown.exit_code == 0, grown.output
    assert board.read_text().startswith(before) and board.read_text().count("\n") == 3  # one episode added
    record = json.loads(board.with_name("board_scored_with.json").read_text())
    assert record["arena_sha256"] == {name: file_sha256(folder / name) for name in FILES}
    assert record["arenas"] == str(folder)
