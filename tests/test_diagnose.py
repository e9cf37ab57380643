"""aaai diagnose on a scoreboard of arena files: each failed row replayed on its arena file, and a
file missing or changed since it was scored refused before any replay; and with a teacher watching
(--teacher): where a student stood or turned against what its teacher asked, the episode unchanged."""

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from aaai.env import AnimalAIEnv
from aaai.files import file_sha256
from aaai_cli.main import cli

# the food 12 units ahead and one second (50 steps) to reach it: random actions fail
ARENA = (
    "description: a tiny test arena\ncategory: food_contact\narena_walls: true\narena_size: [60.0, 60.0]\n"
    "wall_height: 4.0\ntime_limit: 1.0\nagent: {x: 0.0, y: 0.0, yaw: 1.570796}\n"
    "objects:\n  - {kind: food_green, shape: sphere, position: [0.0, 12.0, 2.5], size: [5.0, 5.0, 5.0]}\n"
)


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """Two tiny arena files scored with random actions by aaai eval --arenas (both episodes fail)."""
    root = tmp_path_factory.mktemp("arenas")
    folder = root / "battery"
    folder.mkdir()
    for name in ("a.yaml", "b.yaml"):
        (folder / name).write_text(ARENA)
    board = root / "random.csv"
    result = CliRunner().invoke(
        cli, ["eval", "--arenas", str(folder), "--policy", "random", "-k", "1", "--out", str(board)]
    )
    assert result.exit_code == 0, result.output
    assert board.read_text().count(",failed,") == 2
    return folder, board


def test_diagnose_replays_the_failed_episodes_of_an_arena_scoreboard(scored):
    folder, board = scored
    result = CliRunner().invoke(cli, ["diagnose", "--policy", "random", "--scoreboard", str(board)])
    assert result.exit_code == 0, result.output
    assert "| level or category | failed episodes replayed |" in result.output
    assert "| category food_contact | 2 | 0 |" in result.output  # both replayed, none fell
    limited = CliRunner().invoke(cli, ["diagnose", "--policy", "random", "--scoreboard", str(board), "--limit", "1"])
    assert limited.exit_code == 0 and "| category food_contact | 1 |" in limited.output, limited.output


def test_diagnose_refuses_an_arena_file_missing_or_changed(scored, tmp_path):
    folder, board = scored
    moved = tmp_path / "moved"
    shutil.copytree(folder, moved)
    (moved / "b.yaml").unlink()
    args = ["diagnose", "--policy", "random", "--scoreboard", str(board)]
    missing = CliRunner().invoke(cli, [*args, "--arenas", str(moved)])
    assert missing.exit_code == 2 and f"{str(moved / 'b.yaml')!r} is missing" in missing.output, missing.output
    assert "b.yaml (seed 0)" in missing.output and "Traceback" not in missing.output
    (moved / "b.yaml").write_text(ARENA.replace("12.0, 2.5", "14.0, 2.5"))
    changed = CliRunner().invoke(cli, [*args, "--arenas", str(moved)])  # its record holds each file's SHA-256
    assert changed.exit_code == 2 and "Traceback" not in changed.output, changed.output
    assert f"{str(moved / 'b.yaml')!r} is not the file {str(board)!r} was scored on" in changed.output
    then, now = file_sha256(folder / "b.yaml"), file_sha256(moved / "b.yaml")
    assert f"SHA-256 {then} recorded, {now} now" in changed.output, changed.output
    unnamed = tmp_path / "unnamed.csv"  # no record: the folder must be given
    shutil.copy(board, unnamed)
    refused = CliRunner().invoke(cli, ["diagnose", "--policy", "random", "--scoreboard", str(unnamed)])
    assert refused.exit_code == 2 and "its record names no arena folder" in refused.output, refused.output


def test_diagnose_replays_an_older_scoreboard_without_hashes_with_a_warning(scored, tmp_path):
    folder, board = scored
    old = tmp_path / "old.csv"  # a scoreboard scored before the record kept each file's SHA-256
    shutil.copy(board, old)
    record = json.loads(board.with_name("random_scored_with.json").read_text())
    del record["arena_sha256"]
    old.with_name("old_scored_with.json").write_text(json.dumps(record))
    result = CliRunner().invoke(cli, ["diagnose", "--policy", "random", "--scoreboard", str(old), "--limit", "1"])
    assert result.exit_code == 0, result.output
    assert "records no SHA-256 of its arena files" in result.output and "cannot be detected" in result.output
    assert "| category food_contact | 1 |" in result.output
    bare = tmp_path / "bare.csv"  # no record at all: the folder given
    shutil.copy(board, bare)
    args = ["diagnose", "--policy", "random", "--scoreboard", str(bare), "--limit", "1", "--arenas", str(folder)]
    unrecorded = CliRunner().invoke(cli, args)
    assert unrecorded.exit_code == 0 and "records no SHA-256 of its arena files" in unrecorded.output
    quiet = CliRunner().invoke(cli, ["diagnose", "--policy", "random", "--scoreboard", str(board), "--limit", "1"])
    assert quiet.exit_code == 0 and "SHA-256" not in quiet.output, quiet.output


def test_diagnose_replays_in_the_environment_the_scoreboard_records(scored, tmp_path):
    from aaai.config import load_config
    from aaai.scoring.diagnose import scored_config

    folder, board = scored  # scored on the quadruped in rotation mode (the default config)
    assert scored_config(board, load_config(body="sphere"), given=False).agent.body == "quadruped"
    other = tmp_path / "sphere.yaml"
    other.write_text("agent: {body: sphere}\n")
    args = ["diagnose", "--policy", "random", "--scoreboard", str(board), "--config", str(other)]
    refused = CliRunner().invoke(cli, args)
    assert refused.exit_code == 2 and "scored in another environment" in refused.output, refused.output
    assert "agent.body: 'quadruped' there, 'sphere' now" in refused.output


# --- a teacher watching the replays (aaai diagnose --teacher) -----------------------------------------------
L0_ROW = {"level": "0", "difficulty": "0", "seed": "3"}  # the food ahead: the reference walks to it from the start


def test_a_teacher_watching_counts_the_decisions_a_standing_student_was_taught_to_move(gait_env):
    from aaai.scoring.diagnose import replay_failure, teacher_for

    def stand(observation):
        return np.zeros(3, np.float32)

    failure = replay_failure(gait_env, stand, L0_ROW, teacher=teacher_for("reference", gait_env))
    assert failure.stood > 0.9 and failure.against == 0.0
    assert replay_failure(gait_env, stand, L0_ROW).stood is None  # no teacher: no such share


def test_in_discrete_mode_the_choices_are_read_as_the_commands_they_stand_for():
    """As in gait mode: a standing student ([0, 0, 0]) is counted standing; the reference's own
    choices never part from it; its choices with right and left swapped turn against it."""
    from aaai.scoring.diagnose import replay_failure, teacher_for
    from aaai.task.reference import ReferenceController

    env = AnimalAIEnv(config={"agent": {"action_mode": "discrete"}})
    try:
        failure = replay_failure(env, lambda o: np.zeros(3, np.int64), L0_ROW, teacher=teacher_for("reference", env))
        assert failure.stood > 0.9 and failure.against == 0.0
        row = {"level": "1", "difficulty": "0", "seed": "3"}  # the food off to one side: it turns to face it
        same = replay_failure(env, ReferenceController(env), row, teacher=teacher_for("reference", env))
        assert same.stood == 0.0 and same.against == 0.0
        own = ReferenceController(env)

        def mirrored(observation):  # the teacher's own choice, right (1) and left (2) swapped
            choice = np.array(own(observation))
            choice[1] = (0, 2, 1)[choice[1]]
            return choice

        mirrored.reset = own.reset
        failure = replay_failure(env, mirrored, row, teacher=teacher_for("reference", env))
        assert failure.against > 0.5 and failure.stood == 0.0
    finally:
        env.close()


def test_a_student_that_does_what_its_teacher_does_never_parts_from_it_and_plays_the_same_episode(gait_env):
    from aaai.scoring.diagnose import replay_failure, teacher_for
    from aaai.task.reference import ReferenceController

    alone = replay_failure(gait_env, ReferenceController(gait_env), L0_ROW)
    watched = replay_failure(
        gait_env, ReferenceController(gait_env), L0_ROW, teacher=teacher_for("reference", gait_env)
    )
    assert watched.stood == 0.0 and watched.against == 0.0
    assert (watched.seen_share, watched.food_eaten, watched.cause) == (alone.seen_share, alone.food_eaten, alone.cause)


def test_a_student_that_turns_the_other_way_from_its_teacher_is_counted_turning_against_it(gait_env):
    from aaai.scoring.diagnose import replay_failure, teacher_for
    from aaai.task.reference import ReferenceController

    own = ReferenceController(gait_env)

    def mirrored(observation):  # the teacher's own command, its turn the other way round
        action = np.array(own(observation), np.float32)
        action[1] = -action[1]
        return action

    mirrored.reset = own.reset
    row = {"level": "1", "difficulty": "0", "seed": "3"}  # the food off to one side: it turns to face it
    failure = replay_failure(gait_env, mirrored, row, teacher=teacher_for("reference", gait_env))
    assert failure.against > 0.5 and failure.stood == 0.0


def test_diagnose_with_a_teacher_refuses_a_scoreboard_not_scored_in_gait_mode(scored):
    folder, board = scored  # scored in the default action mode
    result = CliRunner().invoke(
        cli, ["diagnose", "--policy", "random", "--scoreboard", str(board), "--teacher", "reference"]
    )
    assert result.exit_code == 2
    assert "--teacher" in result.output and "gait" in result.output and "rotation" in result.output
