"""A checkpoint written mid-rollout is the model as it was at that step: its file holds the weights
and counters the learner had when the step count passed the mark, and read back (without
unpickling, or by stable-baselines3's own loader) it acts exactly as the learner did then. The
final model is the same learner one PPO update later. So a checkpoint's score is the score of the
policy at its step, and a swing between a checkpoint and the final model is the policy's own."""

import copy
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the checkpoint tests train PPO (the train extra)")

import torch  # noqa: E402

from aaai.config import load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.scoring import model_io  # noqa: E402
from aaai.scoring.model_archive import read_archive, read_tensors  # noqa: E402
from aaai.scoring.policies import ModelPolicy, model_run_config  # noqa: E402
from aaai.train import learner  # noqa: E402
from aaai.train.training import train  # noqa: E402

N_STEPS, CHECKPOINT_EVERY, TOTAL = 32, 40, 96  # the checkpoint at 40 lies inside the rollout 32-64


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A tiny PPO gait run, and what its learner held at each save: weights, counters, actions."""
    config = load_config(
        {
            "agent": {"action_mode": "gait"},
            "episode": {"max_steps": 30},
            "curriculum": {"levels": "0", "difficulties": "0-1"},
            "train": {
                "num_envs": 1,
                "n_steps": N_STEPS,
                "batch_size": 32,
                "n_epochs": 2,
                "net_width": 16,
                "total_steps": TOTAL,
                "checkpoint_every": CHECKPOINT_EVERY,
                "heatmap_every": 10_000,
            },
        }
    )
    run = tmp_path_factory.mktemp("fidelity") / "run"
    seen: dict[int, dict] = {}
    observations: list = []
    saving = learner.save_model

    def recording(model, path, run_config):
        if not observations:
            env = AnimalAIEnv(config=run_config)
            observation, _ = env.reset(seed=3)
            rng = np.random.default_rng(0)
            for _ in range(12):
                observations.append(copy.deepcopy(observation))
                action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
                observation, *_ = env.step(action)
            env.close()
        seen[model.num_timesteps] = {
            "weights": {k: v.detach().clone() for k, v in model.policy.state_dict().items()},
            "n_updates": model._n_updates,
            "actions": np.array([model.predict(o, deterministic=True)[0] for o in observations]),
        }
        return saving(model, path, run_config)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(learner, "save_model", recording)
        train(run, config, asynchronous=False)
    points = sorted(run.glob("checkpoints/step_*")) + [run / "final"]
    return run, points, seen, observations


def _step(point: Path) -> int:
    return json.loads((point / "state.json").read_text())["step"]


def test_a_checkpoint_holds_the_learners_weights_and_counters_at_its_step(trained):
    run, points, seen, _ = trained
    assert [_step(p) for p in points] == [40, 80, 96]  # two mid-rollout (32-64, 64-96), then after the last update
    for point in points:
        step = _step(point)
        weights = read_tensors(point / "model.zip", "policy.pth", trust_helps=False)
        assert set(weights) == set(seen[step]["weights"])
        assert all(torch.equal(weights[k], seen[step]["weights"][k]) for k in weights), point.name
        data = read_archive(point / "model.zip").data
        assert (data["num_timesteps"], data["_n_updates"]) == (step, seen[step]["n_updates"])
    # each has seen the updates of the rollouts finished before its step (n_epochs 2 a update): 1, 2, then all 3
    assert [seen[_step(p)]["n_updates"] // 2 for p in points] == [1, 2, 3]


@pytest.mark.parametrize("trust", [False, True], ids=["model_io", "trust-model"])
def test_a_checkpoint_read_back_acts_as_the_learner_did_at_its_step(trained, trust):
    run, points, seen, observations = trained
    env = AnimalAIEnv(config=load_config(run / "config.yaml"))
    try:
        for point in points:
            path, step = point / "model.zip", _step(point)
            assert model_run_config(path) == load_config(run / "config.yaml")  # scored in the run's own env
            if trust:
                network = model_io.load_for_training(path, None, trust=True).policy  # stable-baselines3's loader
            else:
                network = model_io.load_policy_network(path, env.observation_space, env.action_space)
            actions = np.array([network.predict(o, deterministic=True)[0] for o in observations])
            np.testing.assert_array_equal(actions, seen[step]["actions"], err_msg=point.name)  # float32, bit for bit
            scored = ModelPolicy(path, env, trust, (), model_run_config(path))  # as aaai eval scores it (float64)
            np.testing.assert_allclose([scored(o) for o in observations], seen[step]["actions"], atol=1e-6)
    finally:
        env.close()


def test_a_checkpoint_and_the_final_model_are_scored_alike_on_the_curve(trained, tmp_path):
    """The curve scores a checkpoint through its model file and the final point through the run's
    scoreboard: the same model both ways plays the same episodes, in the same config and numerics."""
    import csv
    import shutil

    from aaai.files import file_sha256
    from aaai.scoring.runs import RunFolder
    from aaai.train.experiments import Experiment, score_checkpoints, score_run

    source, *_ = trained
    run = RunFolder(shutil.copytree(source, tmp_path / "run"))
    twin = run.checkpoints / "step_000000000095"  # the final model, saved as a checkpoint one step before
    twin.mkdir()
    shutil.copy(run.final / "model.zip", twin / "model.zip")
    (twin / "state.json").write_text(json.dumps({**json.loads((run.final / "state.json").read_text()), "step": 95}))
    experiment = Experiment(tmp_path, ["uniform"], [0], load_config(run.path / "config.yaml"), 1, 1)
    played: dict[tuple[str, int], list] = {}  # (model file, seed) -> the actions it took
    init, reset, act = ModelPolicy.__init__, ModelPolicy.reset, ModelPolicy.__call__

    def logged_init(policy, path, *args, **kwargs):
        policy.path = path
        init(policy, path, *args, **kwargs)

    def logged_reset(policy, seed):
        policy.episode = played.setdefault((str(policy.path), seed), [])
        return reset(policy, seed)

    def logged_act(policy, observation):
        action = act(policy, observation)
        policy.episode.append(np.asarray(action).copy())
        return action

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ModelPolicy, "__init__", logged_init)
        patch.setattr(ModelPolicy, "reset", logged_reset)
        patch.setattr(ModelPolicy, "__call__", logged_act)
        score_run(experiment, run, echo=lambda _: None)
        score_checkpoints(experiment, run, echo=lambda _: None)

    def board(path: Path) -> list[dict]:
        with open(path) as handle:
            return [{k: v for k, v in row.items() if k != "wall_seconds"} for row in csv.DictReader(handle)]

    def record(path: Path) -> dict:
        return json.loads(path.with_name(path.stem + "_scored_with.json").read_text())

    final = run.path / "scoreboard_reserved.csv"
    curve = {int(p.stem.split("_")[1]): p for p in (run.path / "curve").glob("reserved_*.csv")}
    assert sorted(curve) == [40, 80, 95]
    assert board(curve[95]) == board(final)  # one model, scored as a checkpoint and as the final model
    seeds = [int(row["seed"]) for row in board(curve[95])]
    for seed in seeds:  # ... acts alike, action for action
        as_final, as_checkpoint = played[(str(run.final / "model.zip"), seed)], played[(str(twin / "model.zip"), seed)]
        assert len(as_final) == len(as_checkpoint) > 0
        np.testing.assert_array_equal(as_final, as_checkpoint)
    assert not np.array_equal(
        played[(str(run.checkpoints / "step_000000000040" / "model.zip"), seeds[0])],
        played[(str(run.final / "model.zip"), seeds[0])],
    )  # another model acts otherwise
    for step, path in curve.items():
        ours, theirs = record(path), record(final)
        file = run.checkpoints / f"step_{step:012d}" / "model.zip"
        assert ours.pop("model_sha256") == file_sha256(file)
        for key in ("model", "model_sha256", "policy"):
            theirs.pop(key)
            ours.pop(key, None)
        assert ours == theirs  # the same env config, action mode, numerics and seeds
    with open(run.path / "curve.csv") as handle:
        assert [int(row["step"]) for row in csv.DictReader(handle)] == [40, 80, 95, 96]


def test_eval_checkpoints_scores_each_checkpoint_and_the_final_model_on_the_same_episodes(trained, tmp_path):
    """`aaai eval --policy RUN --checkpoints`: a curve point per checkpoint and the final model, each the
    pass rate on the same reserved episodes as that model's own eval; resumed without playing again;
    scored again over other episodes; drawn by `aaai plot RUN/curve.csv`."""
    import csv
    import shutil

    from conftest import aaai_here

    source, *_ = trained
    run = shutil.copytree(source, tmp_path / "run")
    args = ["eval", "--policy", run, "--checkpoints", "--levels", "0", "--difficulty", "0-1", "-k", "2"]
    first = aaai_here(*args)
    with open(run / "curve.csv") as handle:
        curve = list(csv.DictReader(handle))
    assert [int(r["step"]) for r in curve] == [40, 80, _step(run / "final")]
    assert {r["episodes"] for r in curve} == {"4"}  # 2 cells x 2 reserved seeds, every point
    assert all(float(r["seconds"]) > 0 for r in curve)  # the training wall time to each point
    for row in curve:  # each point is that model's own scoreboard on those episodes
        point = run / "final" if row is curve[-1] else run / "checkpoints" / f"step_{int(row['step']):012d}"
        own = aaai_here(
            "eval",
            "--policy",
            point / "model.zip",
            "--levels",
            "0",
            "--difficulty",
            "0-1",
            "-k",
            "2",
            "--config",
            run / "config.yaml",
            "--out",
            tmp_path / f"own_{row['step']}.csv",
        )
        with open(tmp_path / f"own_{row['step']}.csv") as handle:
            passed = sum(r["outcome"] != "failed" for r in csv.DictReader(handle))
        assert int(row["passed"]) == passed, own.stdout
    assert first.stdout.count("scoring the") == 3 and "| 40 |" in first.stdout
    again = aaai_here(*args)
    assert "scoring the" not in again.stdout and "3 point(s) scored" in again.stdout
    wider = aaai_here(*args[:-1], "3")  # -k 3: every point scored again, its 2 seeds' rows kept
    assert wider.stdout.count("scoring the") == 3
    with open(run / "curve.csv") as handle:
        assert {r["episodes"] for r in csv.DictReader(handle)} == {"6"}
    drawn = aaai_here("plot", run / "curve.csv", "--out", tmp_path / "curve.png")
    assert (tmp_path / "curve.png").stat().st_size > 1000, drawn.stdout


def test_eval_checkpoints_refuses_what_it_cannot_use(trained, tmp_path):
    from conftest import aaai_here

    source, *_ = trained
    cases = [
        (["--policy", source, "--checkpoints", "--out", tmp_path / "x.csv"], "--checkpoints: got --out"),
        (["--policy", source, "--checkpoints", "--seeds", "train"], "--checkpoints: got --seeds"),
        (["--policy", source, "--checkpoint-every", "50"], "allowed: only with --checkpoints"),
        (["--policy", "random", "--checkpoints"], "allowed: a run folder"),
    ]
    for extra, message in cases:
        result = aaai_here("eval", *extra, check=False)
        assert result.returncode == 2 and message in result.stderr + result.stdout, (extra, result.stdout)
        assert not (source / "curve.csv").exists()


def test_every_nth_keeps_the_first_checkpoint_at_or_past_each_mark():
    from aaai.scoring.curves import every_nth

    points = [(step, Path(str(step))) for step in (10, 20, 30, 55, 74, 75, 76)]
    assert [s for s, _ in every_nth(points, 25)] == [10, 30, 55, 75]
    assert every_nth(points, 0) == points
