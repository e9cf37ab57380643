"""The curricula experiment as a user runs it (`aaai experiment curricula`, `make curricula`): its runs,
scoreboards and table, what it continues and what it refuses."""

import csv
import shutil
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from conftest import aaai, aaai_here

from aaai_cli.main import cli


@pytest.mark.parametrize("jobs", [1, pytest.param(2, marks=pytest.mark.long)])
def test_curricula_experiment_runs_scores_and_resumes(tmp_path, jobs):
    config = tmp_path / "random.yaml"
    config.write_text(
        yaml.safe_dump(
            {"episode": {"max_steps": 50}, "train": {"agent": "random", "checkpoint_every": 100, "heatmap_every": 100}}
        )
    )
    args = [
        "experiment",
        "curricula",
        "--samplers",
        "paper,plr",
        "--seeds",
        "0",
        "--steps",
        200,
        "--levels",
        0,
        "--difficulty",
        "0-1",
        "-k",
        1,
        "--envs",
        1,
        "--config",
        config,
        "--out",
        tmp_path / "exp",
        "--jobs",
        jobs,
    ]
    first = aaai(*args)
    from aaai.config import RULES

    assert f"action mode {'gait' if 'gait' in RULES['agent.action_mode'].choices else 'rotation'}" in first.stdout
    folder = tmp_path / "exp"
    with open(folder / "runs.csv") as handle:
        runs = list(csv.DictReader(handle))
    assert [(r["sampler"], r["seed"]) for r in runs] == [("paper", "0"), ("plr", "0")]
    assert all(
        r["reserved_episodes"] == "2" and r["trained_episodes"] == "2" and r["cells_played"] == "2" for r in runs
    )
    for sampler in ("paper", "plr"):
        run = folder / f"{sampler}-seed0"
        assert yaml.safe_load((run / "config.yaml").read_text())["curriculum"]["sampler"] == sampler
        with open(run / "episodes.csv") as handle:
            played = {int(row["seed"]) for row in csv.DictReader(handle)}
        with open(run / "scoreboard_trained.csv") as handle:
            assert {int(row["seed"]) for row in csv.DictReader(handle)} <= played  # seeds it trained on
    with open(folder / "table.csv") as handle:
        assert [row["sampler"] for row in csv.DictReader(handle)] == ["paper", "plr"]
    assert "| paper | 1 |" in (folder / "table.md").read_text() and (folder / "curves.png").stat().st_size > 1000
    again = (aaai if jobs > 1 else aaai_here)(*args)  # with jobs, the workers' lines reach only a real stdout
    assert again.stdout.count("skipped") == 6  # two runs and four scoreboards, all done
    other = aaai_here(*[a if a != 200 else 300 for a in args], check=False)
    assert other.returncode == 2 and "another config" in other.stderr


# --- continuing the curricula experiment ------------------------------------------------------
REPO = Path(__file__).resolve().parent.parent
PPO_KEYS = (
    "n_steps",
    "batch_size",
    "n_epochs",
    "net_width",
    "learning_rate",
    "gamma",
    "gae_lambda",
    "ent_coef",
    "log_std_init",
    "reward_shaping",
    "proprioception",
)


def make_curricula_command() -> list[str]:
    """The arguments `make curricula` gives `aaai` (its recipe in the Makefile), without CURRICULA_ARGS."""
    lines = (REPO / "Makefile").read_text().splitlines()
    recipe = lines[lines.index(next(line for line in lines if line.startswith("curricula:"))) + 1]
    words = recipe.split()
    assert words[0] == "$(BIN)/aaai" and words[-1] == "$(CURRICULA_ARGS)", recipe
    return words[1:-1]


def changed_defaults(tmp_path, monkeypatch) -> None:
    """configs/default.yaml with PPO's settings, the camera's look and the sampler changed."""
    from aaai import config as config_module

    folder = tmp_path / "configs"
    shutil.copytree(config_module.config_dir(), folder)
    defaults = yaml.safe_load((folder / "default.yaml").read_text())
    train = defaults["train"]
    train.update(
        n_steps=train["n_steps"] * 2,
        batch_size=train["batch_size"] // 2,
        n_epochs=train["n_epochs"] + 1,
        net_width=train["net_width"] * 2,
        learning_rate=train["learning_rate"] * 2,
        gamma=train["gamma"] / 2,
        gae_lambda=train["gae_lambda"] / 2,
        ent_coef=train["ent_coef"] + 0.01,
        log_std_init=train["log_std_init"] - 0.5,
        reward_shaping=train["reward_shaping"] + 1,
        proprioception=not train["proprioception"],
        num_envs=train["num_envs"] + 1,
    )
    defaults["sensors"]["camera_look"] = "task" if defaults["sensors"]["camera_look"] == "classic" else "classic"
    defaults["curriculum"]["sampler"] = "learnability"
    (folder / "default.yaml").write_text(yaml.safe_dump(defaults, sort_keys=False))
    monkeypatch.setattr(config_module, "config_dir", lambda: folder)


@pytest.mark.parametrize("defaults", ["today's", "PPO's changed"])
def test_make_curricula_continues_the_committed_experiment(tmp_path, monkeypatch, defaults):
    """The command `make curricula` runs, through the CLI, accepts experiments/curricula/experiment.yaml
    as the experiment it continues (a copy: the committed folder is not touched); goes red when a
    default the experiment depends on changes and configs/curricula.yaml does not pin it."""
    import aaai.train.experiments as experiments

    committed = yaml.safe_load((REPO / "experiments" / "curricula" / "experiment.yaml").read_text())
    pinned = yaml.safe_load((REPO / "configs" / "curricula.yaml").read_text())
    assert {key: pinned["train"][key] for key in PPO_KEYS} == {
        key: committed["config"]["train"][key] for key in PPO_KEYS
    }
    if defaults != "today's":
        changed_defaults(tmp_path, monkeypatch)
    work = tmp_path / "clone"
    (work / "experiments" / "curricula").mkdir(parents=True)
    shutil.copy(REPO / "experiments" / "curricula" / "experiment.yaml", work / "experiments" / "curricula")
    monkeypatch.chdir(work)
    continued = []

    def not_trained(experiment, **options):
        continued.append(experiment)
        (experiment.folder / "table.md").write_text("")

    monkeypatch.setattr(experiments, "run_experiment", not_trained)
    result = CliRunner().invoke(cli, make_curricula_command())
    assert result.exit_code == 0, result.output
    assert result.output.startswith("experiment experiments/curricula: "), result.output
    (experiment,) = continued
    assert experiment.samplers == committed["samplers"] and experiment.seeds == committed["seeds"]
    run = experiment.run_config("paper", 0)
    assert {key: getattr(run.train, key) for key in PPO_KEYS} == {
        key: committed["config"]["train"][key] for key in PPO_KEYS
    }


def test_curricula_experiment_refused_names_what_differs_and_what_to_do(tmp_path):
    from aaai.config import ConfigError, load_config
    from aaai.train.experiments import plan

    base = {"curriculum": {"levels": "0", "difficulties": "0"}, "train": {"total_steps": 100}}
    plan(tmp_path, ["paper"], [0], load_config(base), 5)
    other = load_config(base, n_epochs=3)
    with pytest.raises(ConfigError) as refused:
        plan(tmp_path, ["paper"], [0], other, 5)
    message = str(refused.value)
    assert "train.n_epochs: 10 in the folder, 3 now" in message
    assert "--config" in message and "another --out" in message
    many = load_config(
        base, n_epochs=3, n_steps=64, batch_size=64, net_width=32, gamma=0.9, gae_lambda=0.9, ent_coef=0.1
    )
    with pytest.raises(ConfigError) as refused:
        plan(tmp_path, ["paper"], [0], many, 4)
    message = str(refused.value)
    assert "K (-k, seeds per cell): 5 in the folder, 4 now" in message
    assert message.count(" in the folder, ") == 5 and "and 3 more" in message  # 8 differences, 5 listed
    assert (
        yaml.safe_load((tmp_path / "experiment.yaml").read_text())["config"] == load_config(base).to_dict()
    )  # not rewritten


def test_curricula_experiment_continues_whatever_the_base_sampler_and_seed(tmp_path):
    """Each run sets its own curriculum.sampler and train.seed: the base config's do not matter."""
    from aaai.config import load_config
    from aaai.train.experiments import plan

    base = {"curriculum": {"levels": "0", "difficulties": "0"}, "train": {"total_steps": 100}}
    plan(tmp_path, ["paper", "plr"], [0], load_config(base, sampler="paper", seed=0), 5)
    experiment = plan(tmp_path, ["uniform"], [1], load_config(base, sampler="uniform", seed=7), 5)
    assert experiment.samplers == ["paper", "plr", "uniform"] and experiment.seeds == [0, 1]
    assert experiment.run_config("plr", 1).curriculum.sampler == "plr"
    assert experiment.run_config("plr", 1).train.seed == 1


def test_make_curricula_on_a_clone_skips_the_committed_runs_it_has_no_model_of(tmp_path, monkeypatch):
    """A clone has the committed runs' states and scoreboards, not their models: continuing the
    experiment skips them (nothing trained, nothing scored) and writes its table again."""
    import aaai.scoring.evaluation as evaluation
    import aaai.train.training as training

    folder = tmp_path / "experiments" / "curricula"
    shutil.copytree(
        REPO / "experiments" / "curricula", folder, ignore=shutil.ignore_patterns("model.zip", "checkpoints", "tb")
    )
    monkeypatch.chdir(tmp_path)
    for module, name in ((training, "train"), (evaluation, "evaluate")):
        monkeypatch.setattr(module, name, lambda *a, _name=name, **k: pytest.fail(f"{_name} was called"))
    result = CliRunner().invoke(cli, [*make_curricula_command(), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    committed = yaml.safe_load((REPO / "experiments" / "curricula" / "experiment.yaml").read_text())
    runs = len(committed["samplers"]) * len(committed["seeds"])
    assert result.output.count("and scored, without its model (not kept), skipped") == runs, result.output
    assert result.output.count("), skipped") == 3 * runs  # each run, and its two scoreboards
    assert (folder / "table.md").read_text() == (REPO / "experiments" / "curricula" / "table.md").read_text()


def test_an_unknown_sampler_of_the_curricula_experiment_is_named(tmp_path):
    from aaai.config import ConfigError
    from aaai.train.experiments import plan

    with pytest.raises(ConfigError, match=r"--samplers: got 'paper,unifrom' \('unifrom' is not a sampler\); allowed"):
        plan(tmp_path / "exp", ["paper", "unifrom"], [0], {}, 1)
    assert not (tmp_path / "exp").exists()
