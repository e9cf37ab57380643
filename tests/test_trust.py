"""Trust at the boundaries: a model file runs no code as it loads, a model is checked against the
environment before any episode, scoreboards record what they were scored with and cannot mix, and
a write that fails names its file and keeps the rows written before it."""

import base64
import csv
import errno
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

pytest.importorskip("stable_baselines3", reason="needs the train extra")

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.scoring import model_archive, model_io, rllib_checkpoints  # noqa: E402
from aaai.scoring.evaluation import record_path  # noqa: E402
from aaai.scoring.policies import ModelPolicy  # noqa: E402
from aaai.scoring.runs import RunFolder  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

SHORT = {"episode": {"max_steps": 15}}


class _Creates:
    """Unpickling this runs code: it creates the file named (the test then looks for it)."""

    def __init__(self, path: Path):
        self.path = str(path)

    def __reduce__(self):
        return exec, (f"open({self.path!r}, 'w').close()",)


def _pickle_creating(path: Path) -> str:
    return base64.b64encode(pickle.dumps(_Creates(path))).decode()


def _rewrite_data(source: Path, target: Path, change) -> Path:
    """A copy of a model file with its data part changed by ``change(data)``."""
    with zipfile.ZipFile(source) as archive:
        parts = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(parts["data"])
    change(data)
    parts["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(target, "w") as archive:
        for name, blob in parts.items():
            archive.writestr(name, blob)
    return target


def _yaml(tmp_path: Path, name: str, config: dict) -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(config))
    return path


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A small PPO trained as `aaai train` trains one (MultiInputPolicy, net_arch, log_std_init), in
    a run folder: run/config.yaml and run/final/model.zip."""
    from stable_baselines3 import PPO

    folder = tmp_path_factory.mktemp("trust")
    config = load_config(SHORT)
    run = RunFolder(folder / "run")
    run.create(config)
    env = AnimalAIEnv(config=config)
    model = PPO(
        "MultiInputPolicy",
        env,
        n_steps=128,
        batch_size=64,
        n_epochs=2,
        seed=0,
        device="cpu",
        policy_kwargs={"net_arch": [32, 32], "log_std_init": -1.0},
    )
    model.learn(256)
    env.close()
    run.save_checkpoint(256, {"curriculum": {}}, save_model=model.save, final=True)
    return folder / "run"


def _eval(*args):
    return CliRunner().invoke(cli, ["eval", "--levels", "0", "--difficulty", "0", "-k", "1", *map(str, args)])


# --- 1. loading runs no code ------------------------------------------------------------------
def test_a_model_loads_without_unpickling_and_acts_as_stable_baselines3_loads_it(trained, monkeypatch):
    from stable_baselines3 import PPO

    path = trained / "final" / "model.zip"
    env = AnimalAIEnv(config=load_config(SHORT))
    original = PPO.load(path, device="cpu")

    def refuse(*args, **kwargs):
        raise AssertionError("something was unpickled")

    for target in ("pickle.loads", "pickle.load", "cloudpickle.loads", "cloudpickle.load"):
        monkeypatch.setattr(target, refuse)
    policy = ModelPolicy(path, env)  # loaded with every unpickler refusing
    monkeypatch.undo()
    observation, _ = env.reset(seed=5)
    for _ in range(40):
        action = policy(observation)
        expected = original.predict(observation, deterministic=True)[0]  # float32's forward pass; ours is float64
        assert np.allclose(action, expected, rtol=0, atol=1e-6)
        observation, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            observation, _ = env.reset(seed=6)
    env.close()


def test_resume_loads_the_whole_model_without_unpickling(trained):
    from stable_baselines3 import PPO

    path = trained / "final" / "model.zip"
    env = AnimalAIEnv(config=load_config(SHORT))
    safe = model_io.load_for_training(path, env)
    original = PPO.load(path, env=env, device="cpu")
    for key in (
        "n_steps",
        "batch_size",
        "n_epochs",
        "gamma",
        "gae_lambda",
        "ent_coef",
        "num_timesteps",
        "seed",
        "_n_updates",
    ):
        assert getattr(safe, key) == getattr(original, key), key
    assert safe.clip_range(1.0) == original.clip_range(1.0) and safe.lr_schedule(0.5) == original.lr_schedule(0.5)
    for name, tensor in original.policy.state_dict().items():
        assert np.array_equal(tensor.numpy(), safe.policy.state_dict()[name].numpy()), name
    assert str(original.policy.optimizer.state_dict()["state"][0]["exp_avg"]) == str(
        safe.policy.optimizer.state_dict()["state"][0]["exp_avg"]
    )
    env.close()


def test_a_model_whose_pickles_would_create_a_file_runs_nothing(trained, tmp_path):
    marker = tmp_path / "pwned"
    config = _yaml(tmp_path, "short.yaml", SHORT)

    # (a) a pickled field we rebuild ourselves (the spaces): dropped unread; the model is scored
    def poison_space(data):
        data["observation_space"][":serialized:"] = _pickle_creating(marker)

    spaced = _rewrite_data(trained / "final" / "model.zip", tmp_path / "spaced.zip", poison_space)
    scored = _eval("--policy", spaced, "--config", config, "--out", tmp_path / "a.csv")
    assert scored.exit_code == 0, scored.output
    assert not marker.exists()

    # (b) a policy class that is not one of ours: refused, naming the field and the flag
    def poison_class(data):
        data["policy_class"] = {
            ":type:": "<class 'type'>",
            ":serialized:": _pickle_creating(marker),
            "__module__": "evil",
            "__init__": "<function Evil.__init__ at 0x0>",
        }

    evil = _rewrite_data(trained / "final" / "model.zip", tmp_path / "evil.zip", poison_class)
    refused = _eval("--policy", evil, "--config", config, "--out", tmp_path / "b.csv")
    assert refused.exit_code == 2 and not marker.exists()
    assert "'policy_class'" in refused.output and "--trust-model" in refused.output and "Evil" in refused.output
    assert not (tmp_path / "b.csv").exists() and not record_path(tmp_path / "b.csv").exists()

    # the pickle is live: --trust-model (stable-baselines3's own loader) does run it
    trusted = _eval("--policy", spaced, "--config", config, "--out", tmp_path / "c.csv", "--trust-model")
    assert marker.exists(), trusted.output


def test_a_schedule_that_is_not_a_constant_is_refused_for_training_naming_it(trained, tmp_path):
    def change(data):
        data["learning_rate"] = {":type:": "<class 'function'>", ":serialized:": "AAAA"}
        data["lr_schedule"] = {":type:": "<class 'function'>", ":serialized:": "AAAA"}

    path = _rewrite_data(trained / "final" / "model.zip", tmp_path / "schedule.zip", change)
    env = AnimalAIEnv(config=load_config(SHORT))
    with pytest.raises(model_archive.UntrustedModel, match="'learning_rate'.*--trust-model"):
        model_io.load_for_training(path, env)
    env.close()


def test_train_resume_unpickles_the_model_only_with_trust_model(trained, tmp_path):
    """``aaai train --resume`` reads the run's model without unpickling; ``--trust-model`` reaches the
    loader as an argument, and then stable-baselines3's own loader runs the file's pickles."""
    marker = tmp_path / "pwned"
    run = tmp_path / "run"
    shutil.copytree(trained, run)
    config = yaml.safe_load((run / "config.yaml").read_text())
    config["train"].update(num_envs=1, vector="sync")  # one worker in this process: quick to start
    (run / "config.yaml").write_text(yaml.safe_dump(config))
    from aaai.train.curriculum import Curriculum

    state = json.loads((run / "final" / "state.json").read_text())
    state["curriculum"] = Curriculum.from_config(load_config(config)).state_dict()
    (run / "final" / "state.json").write_text(json.dumps(state))

    def poison_class(data):
        data["policy_class"] = {
            ":type:": "<class 'type'>",
            ":serialized:": _pickle_creating(marker),
            "__module__": "evil",
            "__init__": "<function Evil.__init__ at 0x0>",
        }

    model = run / "final" / "model.zip"
    _rewrite_data(model, tmp_path / "evil.zip", poison_class).replace(model)
    refused = CliRunner().invoke(cli, ["train", "--resume", str(run), "--steps", "512"])
    assert refused.exit_code == 2 and "'policy_class'" in refused.output and "--trust-model" in refused.output
    assert not marker.exists()
    CliRunner().invoke(cli, ["train", "--resume", str(run), "--steps", "512", "--trust-model"])
    assert marker.exists()


def test_an_rllib_checkpoint_loads_only_signed_here_or_trusted(tmp_path, monkeypatch):
    monkeypatch.setenv("AAAI_CHECKPOINT_KEY", str(tmp_path / "key"))
    checkpoint = tmp_path / "final" / "rllib"
    (checkpoint / "sub").mkdir(parents=True)
    (checkpoint / "sub" / "module_state.pkl").write_bytes(b"weights")
    with pytest.raises(model_archive.UntrustedModel, match="pickles.*--trust-model"):
        rllib_checkpoints.check_rllib_checkpoint(checkpoint)
    rllib_checkpoints.check_rllib_checkpoint(checkpoint, trust=True)
    rllib_checkpoints.sign_checkpoint(checkpoint)
    rllib_checkpoints.check_rllib_checkpoint(checkpoint)  # signed here: loads
    assert oct((tmp_path / "key").stat().st_mode & 0o777) == "0o600"
    (checkpoint / "sub" / "module_state.pkl").write_bytes(b"changed")
    with pytest.raises(model_archive.UntrustedModel):
        rllib_checkpoints.check_rllib_checkpoint(checkpoint)  # a file changed after signing
    rllib_checkpoints.sign_checkpoint(checkpoint)
    monkeypatch.setenv("AAAI_CHECKPOINT_KEY", str(tmp_path / "another_machine"))
    with pytest.raises(model_archive.UntrustedModel):
        rllib_checkpoints.check_rllib_checkpoint(checkpoint)  # signed elsewhere


# --- 2. a model is checked against the environment ------------------------------------------
def test_a_model_that_does_not_fit_the_environment_is_refused_before_any_file(trained, tmp_path):
    model = trained / "final" / "model.zip"
    fewer_rays = _yaml(tmp_path, "rays.yaml", {**SHORT, "sensors": {"rays_per_side": 4}})
    out = tmp_path / "board.csv"
    result = _eval("--policy", model, "--config", fewer_rays, "--out", out)
    assert result.exit_code == 2, result.output
    message = " ".join(result.output.split())
    assert "sensors.rays_per_side: model 8, environment 4" in message
    assert not out.exists() and not record_path(out).exists()
    # a model outside a run folder is checked by its spaces, both sides named
    bare = tmp_path / "bare.zip"
    bare.write_bytes(model.read_bytes())
    result = _eval("--policy", bare, "--config", fewer_rays, "--out", out)
    message = " ".join(result.output.split())
    assert (
        result.exit_code == 2
        and "observation 'rays': model Box(0.0, 1.0, (17, 11), float32), environment Box(0.0, 1.0, (9, 11), float32)"
        in message
    )
    assert not out.exists() and not record_path(out).exists()


def test_a_model_of_another_action_mode_is_refused_naming_both(trained, tmp_path):
    other = _yaml(tmp_path, "velocity.yaml", {**SHORT, "agent": {"action_mode": "velocity"}})
    out = tmp_path / "board.csv"
    result = _eval("--policy", trained / "final" / "model.zip", "--config", other, "--out", out)
    assert result.exit_code == 2
    assert "agent.action_mode: model 'rotation', environment 'velocity'" in " ".join(result.output.split())
    assert not out.exists() and not record_path(out).exists()
    run = CliRunner().invoke(cli, ["run", "--policy", str(trained / "final" / "model.zip"), "--config", str(other)])
    assert run.exit_code == 2 and "agent.action_mode" in run.output


# --- 3. provenance that cannot mix ------------------------------------------------------------
def test_a_failed_eval_leaves_nothing_and_blocks_nothing(tmp_path):
    out = tmp_path / "fe.csv"
    failed = _eval("--policy", "json:nothing_here", "--out", out)
    assert failed.exit_code == 2 and "nothing_here" in failed.output
    assert not out.exists() and not record_path(out).exists()
    config = _yaml(tmp_path, "short.yaml", SHORT)
    scored = _eval("--policy", "reference", "--config", config, "--out", out)
    assert scored.exit_code == 0, scored.output
    record = json.loads(record_path(out).read_text())
    assert record["policy"] == "reference" and record["action_mode"] == "rotation"
    assert record["env_config"]["episode"]["max_steps"] == 15 and len(record["env_config_sha256"]) == 64
    assert record["aaai_version"]


def test_rows_of_another_config_are_refused_naming_the_keys_that_differ(tmp_path):
    out = tmp_path / "board.csv"
    first = _eval("--policy", "random", "--config", _yaml(tmp_path, "a.yaml", SHORT), "--out", out)
    assert first.exit_code == 0, first.output
    before, record = out.read_text(), record_path(out).read_text()
    other = _yaml(tmp_path, "b.yaml", {"episode": {"max_steps": 16}, "sensors": {"ray_length": 10.0}})
    mixed = _eval("--policy", "random", "--config", other, "-k", "2", "--out", out)
    message = " ".join(mixed.output.split())
    assert mixed.exit_code == 2 and "refusing to add episodes" in message
    assert "env_config.episode.max_steps: 15 there, 16 now" in message
    assert "env_config.sensors.ray_length: 15.0 there, 10.0 now" in message
    assert out.read_text() == before and record_path(out).read_text() == record
    same = _eval("--policy", "random", "--config", _yaml(tmp_path, "a.yaml", SHORT), "-k", "2", "--out", out)
    assert same.exit_code == 0 and len(out.read_text().splitlines()) == 3


def test_a_key_added_since_at_its_default_is_no_difference_but_set_otherwise_it_is(tmp_path):
    import hashlib

    out = tmp_path / "board.csv"
    first = _eval("--policy", "random", "--config", _yaml(tmp_path, "a.yaml", SHORT), "--out", out)
    assert first.exit_code == 0, first.output
    record = json.loads(record_path(out).read_text())  # as a scoreboard scored before sensors.sweep_map existed
    del record["env_config"]["sensors"]["sweep_map"]
    record["env_config_sha256"] = hashlib.sha256(json.dumps(record["env_config"], sort_keys=True).encode()).hexdigest()
    record_path(out).write_text(json.dumps(record))
    more = _eval("--policy", "random", "--config", _yaml(tmp_path, "a.yaml", SHORT), "-k", "2", "--out", out)
    assert more.exit_code == 0, more.output
    assert len(out.read_text().splitlines()) == 3
    assert json.loads(record_path(out).read_text())["env_config"]["sensors"]["sweep_map"] == 0
    mapped = _yaml(tmp_path, "b.yaml", {**SHORT, "sensors": {"sweep_map": 5}})
    refused = _eval("--policy", "random", "--config", mapped, "-k", "3", "--out", out)
    message = " ".join(refused.output.split())
    assert refused.exit_code == 2 and "env_config.sensors.sweep_map: 0 there, 5 now" in message  # named since


def test_a_model_file_is_recorded_by_its_hash(trained, tmp_path):
    import hashlib

    out = tmp_path / "board.csv"
    result = _eval("--policy", trained, "--out", out)
    assert result.exit_code == 0, result.output
    record = json.loads(record_path(out).read_text())
    model = trained / "final" / "model.zip"
    assert record["model_sha256"] == hashlib.sha256(model.read_bytes()).hexdigest()


# --- 4. errors at the boundary ------------------------------------------------------------------
def test_a_full_disk_names_the_file_keeps_the_rows_and_a_rerun_resumes(tmp_path, monkeypatch):
    import os

    config = _yaml(tmp_path, "short.yaml", SHORT)
    out = tmp_path / "board.csv"
    real_fsync, calls = os.fsync, []

    def fsync(descriptor):
        calls.append(descriptor)
        if len(calls) == 3:  # the third row (record and atomic writes do not come here)
            raise OSError(errno.ENOSPC, "No space left on device", str(out))
        return real_fsync(descriptor)

    monkeypatch.setattr("aaai.scoring.scoreboard.os.fsync", fsync)
    full = _eval("--policy", "random", "--config", config, "-k", "4", "--out", out)
    assert full.exit_code != 0 and "Traceback" not in full.output
    message = " ".join(full.output.split())
    assert str(out) in message and "No space left on device" in message and "run the same command again" in message
    with open(out) as handle:
        assert len(list(csv.DictReader(handle))) >= 1  # the rows made durable before stay (the failed one is cut)
    monkeypatch.undo()
    resumed = _eval("--policy", "random", "--config", config, "-k", "4", "--out", out)
    assert resumed.exit_code == 0, resumed.output
    with open(out) as handle:
        seeds = [row["seed"] for row in csv.DictReader(handle)]
    assert len(seeds) == 4 and len(set(seeds)) == 4


def test_a_model_file_of_another_kind_is_a_clear_error(tmp_path):
    env = AnimalAIEnv(config=load_config(SHORT))
    text = tmp_path / "notes.zip"
    text.write_text("not a zip")
    with pytest.raises(ConfigError, match="notes.zip"):
        ModelPolicy(text, env)
    env.close()


# --- 5. small traps -----------------------------------------------------------------------------
def test_show_video_runs_to_the_episode_end_and_says_when_steps_cut_it(tmp_path):
    config = _yaml(tmp_path, "short.yaml", SHORT)
    whole = CliRunner().invoke(cli, ["show", "0", "--config", str(config), "--video", str(tmp_path / "a.mp4")])
    assert whole.exit_code == 0, whole.output
    assert "ended at step 15 (reached max_steps)" in whole.output
    cut = CliRunner().invoke(
        cli, ["show", "0", "--config", str(config), "--video", str(tmp_path / "b.mp4"), "--steps", "5"]
    )
    assert cut.exit_code == 0 and "stopped at step 5 by --steps before the episode ended" in cut.output


def test_validate_reports_every_problem_of_an_arena_file_each_with_its_line(tmp_path):
    folder = tmp_path / "arenas"
    folder.mkdir()
    (folder / "many.yaml").write_text(
        "agent: {x: 0, y: 0}\n"
        "objects:\n"
        "- {kind: wall, position: [5, five, 1], size: [1, 1, 1]}\n"
        "- {kind: food_blue, position: [3, 3, 0.5], size: [1, 1, 1]}\n"
        "- {kind: food_green, position: [-5, -5, 0.5], size: [1, 1, 1], mass: -2}\n"
        "time_limit: 0\n"
        "colour: red\n"
    )
    result = CliRunner().invoke(cli, ["validate", "--arena", str(folder), "--seeds", "1"])
    assert result.exit_code == 1
    failed = [line for line in result.output.splitlines() if line.startswith("FAILED")]
    for where in (
        "line 3, objects[0].position[1]",
        "line 4, objects[1].kind",
        "line 5, objects[2].mass",
        "line 6, time_limit",
        "line 7, colour",
    ):
        assert sum(where in line for line in failed) == 1, (where, failed)
    assert len(failed) == 5


def test_objects_that_overlap_exactly_and_numbers_far_out_are_clear_errors(tmp_path):
    from aaai.task.arena import load_arena

    food = "{kind: food_green, position: [-10, -10, 0.5], size: [1, 1, 1]}"
    twice = tmp_path / "twice.yaml"
    twice.write_text(f"agent: {{x: 0, y: 0}}\narena_walls: true\nobjects:\n- {food}\n- {food}\n")
    with pytest.raises(
        ConfigError,
        match=r"twice.yaml line 4, objects\[0\] \(food_green\): at \(-10.0, -10.0\) is "
        r"exactly where objects\[1\]",
    ):
        load_arena(twice)
    far = tmp_path / "far.yaml"
    far.write_text(f"agent: {{x: 1.0e+308, y: 0}}\narena_walls: true\nobjects:\n- {food}\n")
    with pytest.raises(ConfigError, match="agent's start .* lies outside any arena"):
        load_arena(far)


def test_spec_yaml_says_plainly_that_the_arena_it_writes_is_fixed():
    result = CliRunner().invoke(cli, ["spec", "L1", "--yaml"])
    assert result.exit_code == 0
    assert result.output.startswith("# A fixed arena") and "{uniform: [low, high]}" in result.output.splitlines()[1]


@pytest.mark.parametrize("fault", ["permission", "folder"])
def test_a_write_refused_midway_names_the_file_and_a_rerun_resumes(tmp_path, monkeypatch, fault):
    import builtins

    config = _yaml(tmp_path, "short.yaml", SHORT)
    out = tmp_path / "board.csv"
    if fault == "folder":  # a folder where the record file should be
        record_path(out).mkdir()
    else:  # the scoreboard cannot be opened (as root, which writes anywhere, the refusal is injected)
        real_open = builtins.open

        def refusing(file, *args, **kwargs):
            if str(file) == str(out):
                raise PermissionError(errno.EACCES, "Permission denied", str(out))
            return real_open(file, *args, **kwargs)

        monkeypatch.setattr("aaai.scoring.scoreboard.open", refusing, raising=False)
    failed = _eval("--policy", "random", "--config", config, "-k", "2", "--out", out)
    message = " ".join(failed.output.split())
    assert failed.exit_code != 0 and "Traceback" not in failed.output
    named = record_path(out) if fault == "folder" else out
    assert f"'{named}'" in message and ("Permission denied" in message or "Is a directory" in message), message
    assert not out.exists()
    if fault == "folder":
        record_path(out).rmdir()
    monkeypatch.undo()
    resumed = _eval("--policy", "random", "--config", config, "-k", "2", "--out", out)
    assert resumed.exit_code == 0, resumed.output
    assert len(out.read_text().splitlines()) == 3
