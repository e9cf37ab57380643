"""`aaai experiment limbs`: both bodies on the same levels and battery, each arena file scored for the
bodies it is valid for, the gap taken on the tasks valid for both; resumed, run in parts, tabled from
the folder."""

import json

import pytest
from click.testing import CliRunner
from test_sphere_arenas import AGENT, GOAL, HEAD, WALL

from aaai.config import ConfigError, load_config
from aaai.files import file_sha256
from aaai.scoring.runs import RunFolder
from aaai.tools.animalai import import_animalai
from aaai.train.limbs import LimbsSettings, _olympics, run_experiment, summarise, table_markdown
from aaai_cli.main import cli

# Two short Animal-AI tasks (food 4 units ahead): one valid for both bodies, one with a wall 0.8 units
# behind the start, where only the sphere fits.
ARENAS = {
    "01-01-01.yaml": AGENT.format(x=20, z=10) + GOAL.format(x=20, z=14),
    "01-02-01.yaml": AGENT.format(x=20, z=5) + WALL.format(x=20, z=3.7, sx=10, sz=1) + GOAL.format(x=20, z=9),
}
SMALL = ["--levels", "0", "--difficulty", "0", "-k", "1", "--arena-seeds", "1"]


@pytest.fixture(scope="module")
def battery(tmp_path_factory):
    folder = tmp_path_factory.mktemp("limbs_battery")
    (folder / "src").mkdir()
    for name, items in ARENAS.items():
        (folder / "src" / name).write_text(HEAD + items)
    import_animalai(folder / "src", folder / "out", echo=lambda line: None, fitted=False)
    return folder / "out"


def _row(table: str, start: str) -> list[str]:
    line = next(line for line in table.splitlines() if line.startswith(f"| {start} |"))
    return [cell.strip() for cell in line.strip("|").split("|")]


def test_the_experiment_runs_in_parts_scores_each_task_for_the_bodies_it_fits_and_resumes(tmp_path, battery):
    out = tmp_path / "limbs"
    runner = CliRunner()
    arguments = ["experiment", "limbs", *SMALL, "--arenas", str(battery), "--out", str(out)]
    for body in ("sphere", "quadruped"):  # one part per body, as two processes would run them
        result = runner.invoke(cli, [*arguments, "--bodies", body])
        assert result.exit_code == 0, result.output
    assert "2 of 2 arena files valid for the sphere" in runner.invoke(cli, [*arguments, "--bodies", "sphere"]).output
    scored = {path.name: path.read_text() for path in out.glob("*.csv")}
    assert len(scored["reference_sphere_arenas.csv"].splitlines()) == 3  # header and both tasks
    assert len(scored["reference_quadruped_arenas.csv"].splitlines()) == 2  # the one it fits
    assert "not clear: a body of radius 5.0" in scored["tasks_quadruped.csv"]
    record = json.loads((out / "reference_sphere_arenas_scored_with.json").read_text())
    assert record["arena_sha256"] == {f.name: file_sha256(f) for f in battery.glob("*.yaml")}  # changes refused
    assert record["arenas"] == str(battery.resolve())  # where aaai diagnose finds them
    table = (out / "table.md").read_text()
    assert _row(table, "L0")[1] == _row(table, "L0")[3] == "1/1 (100 %)"  # the levels' table: both bodies
    battery_row = _row(table, "all categories")
    assert battery_row[1] == "2, 1, 2, 1"  # files, valid for the quadruped, for the sphere, for both
    assert battery_row[2] == battery_row[4] == "1/1 (100 %)"  # each body on the task valid for both
    assert battery_row[6] == "+0 points"  # the gap, on the tasks valid for both only
    assert battery_row[8:10] == ["-", "1/1 (100 %)"]  # apart: the sphere's task valid for it alone
    again = runner.invoke(cli, arguments)  # both bodies again: nothing played or checked twice
    assert again.exit_code == 0, again.output
    assert again.output.count("(0 checked now") == 2
    assert {path.name: path.read_text() for path in out.glob("*.csv")} == scored
    (out / "table.md").unlink()
    tables = runner.invoke(cli, ["experiment", "limbs", "--tables-only", "--out", str(out)])
    assert tables.exit_code == 0 and (out / "table.md").read_text() == table


def test_a_verdict_is_checked_again_when_the_checking_code_has_changed(tmp_path, battery, monkeypatch):
    import aaai.train.limbs as limbs

    out = tmp_path / "limbs"
    arguments = ["experiment", "limbs", *SMALL, "--arenas", str(battery), "--out", str(out), "--bodies", "quadruped"]
    first = CliRunner().invoke(cli, arguments)
    assert first.exit_code == 0 and "(2 checked now" in first.output, first.output
    assert f",{limbs.checker_fingerprint()}," in (out / "tasks_quadruped.csv").read_text()
    monkeypatch.setattr(limbs, "checker_fingerprint", lambda: "another check")  # a new rule, say
    again = CliRunner().invoke(cli, arguments)
    assert again.exit_code == 0 and "(2 checked now" in again.output, again.output


def test_a_verdict_answers_for_fewer_seeds_and_more_seeds_check_only_the_new_ones(tmp_path, battery, monkeypatch):
    import aaai.task.arena as arena
    from aaai.train.limbs import check_tasks

    checked = []
    real = arena.load_arena

    def load(path, seed=0, **keywords):
        checked.append((path.name, seed))
        if path.name == "01-01-01.yaml" and seed == 3:  # a draw that fails on the fourth seed, say
            raise ConfigError("a piece drawn into a wall")
        return real(path, seed, **keywords)

    monkeypatch.setattr(arena, "load_arena", load)

    def valid(seeds):
        checked.clear()
        found = check_tasks(tmp_path, "quadruped", LimbsSettings(arenas=(battery,), arena_seeds=seeds), print)
        return sorted(file.name for file in found)

    table = tmp_path / "tasks_quadruped.csv"
    assert valid(2) == ["01-01-01.yaml"] and len(checked) == 3  # two seeds, and the other fails on its first
    kept = table.read_text()
    assert valid(1) == ["01-01-01.yaml"] and checked == []  # fewer seeds: nothing checked, nothing rewritten
    assert table.read_text() == kept
    assert valid(3) == ["01-01-01.yaml"] and checked == [("01-01-01.yaml", 2)]  # only the new seed
    assert valid(5) == [] and checked == [("01-01-01.yaml", 3)]  # fails on seed 3
    kept = table.read_text()
    assert "seed 3: a piece drawn into a wall" in kept
    assert valid(3) == ["01-01-01.yaml"] and checked == [] and table.read_text() == kept  # valid before seed 3
    assert valid(4) == [] and checked == []


def test_the_gap_is_taken_on_the_tasks_valid_for_both_and_the_rest_counted_apart():
    category = "Animal-AI 08 object permanence"
    tasks = {
        "quadruped": {"a": {"category": category, "valid": "yes"}, "b": {"category": category, "valid": "no"}},
        "sphere": {"a": {"category": category, "valid": "yes"}, "b": {"category": category, "valid": "yes"}},
    }

    def row(body, arena, won):
        return {"body": body, "policy": "reference", "group": f"category {category}", "arena": arena, "passed": won}

    rows = [row("quadruped", "a", False), row("sphere", "a", True), row("sphere", "b", False)]
    for item in rows:
        item["seconds"] = 40.0
    cells = _row(table_markdown(summarise(rows, tasks), tasks), f"category {category}")
    assert cells[1] == "2, 1, 2, 1"
    assert cells[2] == "0/1 (0 %)" and cells[4] == "1/1 (100 %)" and cells[6] == "+100 points"
    assert cells[8:10] == ["-", "0/1 (0 %)"]  # the sphere's miss on its own task is not in the gap


def test_an_imported_competition_file_is_tabled_under_its_olympics_category():
    assert _olympics("08-17-03.yaml") == "Animal-AI 08 object permanence"
    assert _olympics("tunnel.yaml") == _olympics("11-01-01.yaml") == _olympics("010101.yaml") == "uncategorised"


def test_a_ppo_run_made_for_another_budget_is_refused(tmp_path):
    RunFolder(tmp_path / "runs" / "sphere").create(load_config(None, body="sphere", total_steps=1000))
    settings = LimbsSettings(levels=[0], difficulties=[0], seeds_per_cell=1, ppo_steps=2000, bodies=("sphere",))
    with pytest.raises(ConfigError) as caught:
        run_experiment(tmp_path, LimbsSettings(**{**settings.__dict__, "policies": ("ppo",)}), echo=lambda line: None)
    assert "--ppo-steps: got 2000" in str(caught.value) and "for 1000 agent decisions" in str(caught.value)


def test_a_body_or_policy_not_known_gets_one_clear_message(tmp_path):
    for option, value in (("--bodies", "sphere,blob"), ("--policies", "random")):
        result = CliRunner().invoke(cli, ["experiment", "limbs", option, value, "--out", str(tmp_path)])
        assert result.exit_code == 2 and "Traceback" not in result.output
        assert repr(value) in result.output and "allowed: one or more of" in result.output
    assert not any(tmp_path.iterdir())  # nothing was written


def test_two_arena_files_of_one_name_are_refused_before_anything_runs(tmp_path, battery):
    out = tmp_path / "limbs"
    arguments = ["experiment", "limbs", *SMALL, "--arenas", str(battery), "--arenas", str(battery / "01-01-01.yaml")]
    result = CliRunner().invoke(cli, [*arguments, "--out", str(out)])
    assert result.exit_code == 2 and "two arena files are named 01-01-01.yaml" in result.output
    assert not list(out.glob("*.csv"))  # nothing scored


def test_the_time_ratio_compares_the_episodes_both_bodies_passed():
    def row(body, seed, won, seconds):
        return {"body": body, "policy": "reference", "group": "L0", "episode": (0, 0, seed), "passed": won,
                "seconds": seconds}  # fmt: skip

    rows = [row("quadruped", 1, True, 40.0), row("quadruped", 2, False, 200.0)]
    rows += [row("sphere", 1, True, 10.0), row("sphere", 2, True, 30.0)]
    cells = _row(table_markdown(summarise(rows)), "L0")
    assert cells[2] == "40.0 s" and cells[4] == "20.0 s"  # each body's own passed episodes
    assert cells[6] == "0.25"  # 10 s against 40 s on seed 1, the one both passed (not 20 / 40)
