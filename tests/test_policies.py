"""What a --policy string names (aaai.scoring.policies): read once into plain data, refused with a clear
message when it names nothing usable, and built into the same acting policy wherever it goes."""

from __future__ import annotations

import hashlib
import json
import pickle
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import needs

from aaai.config import Config, ConfigError, env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.scoring.evaluation import policy_record
from aaai.scoring.policies import GRID, ModelPolicy, Policy, RandomPolicy, check_model, external, on_grid, resolve
from aaai.scoring.runs import RunFolder

SHORT = {"episode": {"max_steps": 20}}


def _save_model(config: Config, path: Path) -> None:
    from stable_baselines3 import PPO

    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        model = PPO(
            "MultiInputPolicy", env, n_steps=64, batch_size=64, seed=0, device="cpu", policy_kwargs={"net_arch": [8]}
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        model.save(path)
    finally:
        env.close()


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    """A run folder as the trainer leaves it: its config (4 rays a side, 20-step episodes), an older
    checkpoint and final/, each with a model."""
    needs("stable_baselines3", "train")
    folder = tmp_path_factory.mktemp("policies") / "run"
    config = load_config({**SHORT, "sensors": {"rays_per_side": 4}})
    RunFolder(folder).create(config)
    for point, step in (("checkpoints/step_000000000100", 100), ("final", 200)):
        _save_model(config, folder / point / "model.zip")
        (folder / point / "state.json").write_text(json.dumps({"step": step, "curriculum": {}}))
    return folder


def test_a_built_in_name_is_its_own_kind_and_record():
    for name in ("random", "reference", "gait"):
        policy = resolve(name)
        assert (policy.kind, policy.file, policy.run, policy.record) == (name, None, None, {"policy": name})
    env = AnimalAIEnv(config=load_config(SHORT))
    try:
        assert isinstance(resolve("random").build(env), RandomPolicy)
        assert type(resolve("reference").build(env).policy).__name__ == "ReferenceController"  # on the grid
        assert type(resolve("gait").build(env)).__name__ == "SineGait"
    finally:
        env.close()


def test_a_run_folder_names_its_newest_model_with_its_hash_and_its_config(run):
    policy = resolve(str(run))
    model = run / "final" / "model.zip"
    assert (policy.kind, policy.file, policy.run) == ("model", str(model), str(run))
    assert policy.record == {
        "policy": str(run),
        "model": str(model),
        "model_sha256": hashlib.sha256(model.read_bytes()).hexdigest(),
    }
    assert policy.key == policy.record["model_sha256"]
    assert policy.config().sensors.rays_per_side == 4  # the run's own senses by default
    assert policy.config().episode.max_steps == 20
    assert policy.config(None) == policy.config()
    assert policy_record(policy, "reserved")["model_sha256"] == policy.record["model_sha256"]


def test_an_explicit_config_wins_over_the_runs(run, tmp_path):
    config = tmp_path / "other.yaml"
    config.write_text("sensors:\n  rays_per_side: 6\n")
    assert resolve(str(run)).config(str(config)).sensors.rays_per_side == 6
    bare = resolve(str(run / "checkpoints" / "step_000000000100" / "model.zip"))
    assert bare.run is None and bare.file.endswith("step_000000000100/model.zip")
    assert bare.config().sensors.rays_per_side == 4  # a checkpoint's file: scored with its run's senses
    assert bare.config(str(config)).sensors.rays_per_side == 6  # unless a config is given
    alone = tmp_path / "alone.zip"
    shutil.copy(bare.file, alone)
    assert resolve(str(alone)).config().sensors.rays_per_side == 8  # a file outside a run: the defaults


def test_the_value_pickles_and_builds_the_same_policy_from_a_copy_of_its_file(run, tmp_path):
    """What a Ray task gets: the resolved policy as plain data, and the model's bytes in a file of its own."""
    policy = resolve(str(run))
    again = pickle.loads(pickle.dumps(policy))
    assert again == policy and again.record == policy.record and again.run_config == policy.run_config
    copy = tmp_path / "copy.zip"
    shutil.copy(policy.file, copy)
    moved = again.with_file(copy)
    assert moved.file == str(copy) and moved.record == policy.record
    env = AnimalAIEnv(config=policy.config())
    try:
        here, there = policy.build(env), moved.build(env)
        observation, _ = env.reset(seed=3)
        for _ in range(5):
            action = here(observation)
            assert np.array_equal(action, there(observation))
            observation, *_ = env.step(action)
    finally:
        env.close()


def test_a_model_is_refused_in_an_environment_its_run_did_not_train_in(run):
    policy = resolve(str(run / "final" / "model.zip"))
    env = AnimalAIEnv(config=load_config(SHORT))  # 8 rays a side
    try:
        with pytest.raises(ConfigError, match=r"sensors.rays_per_side: model 4, environment 8.*--config .*config.yaml"):
            policy.build(env)
    finally:
        env.close()


def test_only_the_settings_that_matter_are_compared():
    trained = load_config({"sensors": {"rays_per_side": 4, "camera": False}})
    env = AnimalAIEnv(config=load_config({"sensors": {"rays_per_side": 4, "camera": False, "camera_resolution": 32}}))
    try:
        check_model(Path("m.zip"), env, (), trained)  # the camera is off on both sides: its size does not count
        check_model(Path("m.zip"), env, (), None)  # a model outside a run folder: nothing to compare
        other = load_config({"sensors": {"rays_per_side": 5}})
        with pytest.raises(ConfigError, match=r"sensors.rays_per_side: model 5, environment 4") as caught:
            check_model(Path("run/final/m.zip"), env, (), other)
        assert "camera_resolution" not in str(caught.value)
        assert f"--config {Path('run').absolute() / 'config.yaml'}" in str(caught.value)
        mode = load_config({"sensors": {"rays_per_side": 4}, "agent": {"action_mode": "gait"}})
        with pytest.raises(ConfigError, match=r"agent.action_mode: model 'gait', environment 'rotation'"):
            check_model(Path("run/checkpoints/step_1/m.zip"), env, (), mode)
        with pytest.raises(ConfigError, match=rf"--config {Path('run').absolute() / 'config.yaml'}"):
            check_model(Path("run/checkpoints/step_1/m.zip"), env, (), mode)
    finally:
        env.close()


def test_a_camera_the_caller_added_is_not_compared():
    trained = load_config({"sensors": {"camera": False}})
    env = AnimalAIEnv(config=load_config({"sensors": {"camera": True, "camera_resolution": 16}}))
    try:
        with pytest.raises(ConfigError, match="sensors.camera: model False, environment True"):
            check_model(Path("m.zip"), env, (), trained)
        with pytest.raises(ConfigError, match="camera"):
            check_model(Path("m.zip"), env, ("rays",), trained)
        check_model(Path("m.zip"), env, ("camera",), trained)  # aaai show turned it on to draw it
    finally:
        env.close()


def test_a_model_without_an_environment_is_refused_naming_it(run):
    with pytest.raises(ConfigError, match=r"model.zip.*an environment is needed"):
        ModelPolicy(Path(run / "final" / "model.zip"), None)


@pytest.mark.parametrize(
    "text, message",
    [
        ("missing.zip", r"model file 'missing.zip' does not exist"),
        (
            "nonsense",
            r"'nonsense' is no run folder or model file here; allowed: random, reference, search, search_strict, "
            r"search_thorough, gait, a model .zip",
        ),
        (
            "runs/nothing",
            r"'runs/nothing' is no run folder or model file here; allowed: random, reference, search, search_strict, "
            r"search_thorough, gait",
        ),
        ("no_such_module_here:make", r"cannot load 'no_such_module_here:make'"),
        ("json:no_such_name", r"cannot load 'json:no_such_name'"),
    ],
)
def test_a_string_that_names_no_policy_is_refused_naming_it(text, message):
    with pytest.raises(ConfigError, match=message):
        resolve(text)


def test_a_damaged_model_file_is_refused_naming_the_problem(tmp_path):
    path = tmp_path / "broken.zip"
    path.write_bytes(b"")
    with pytest.raises(ConfigError, match=r"model file '.*broken.zip' cannot be loaded: broken.zip is empty"):
        resolve(str(path))


def test_a_folder_that_is_no_run_or_holds_no_model_is_refused(tmp_path, run):
    with pytest.raises(FileNotFoundError, match="is not a run folder"):
        resolve(str(tmp_path))
    empty = tmp_path / "empty"
    RunFolder(empty).create(load_config(SHORT))
    with pytest.raises(
        ConfigError, match=r"run folder '.*empty' holds no model \(final/ or checkpoints/\*/model.zip\)"
    ):
        resolve(str(empty))
    damaged = tmp_path / "damaged"
    shutil.copytree(run, damaged)
    (damaged / "final" / "model.zip").write_bytes(b"")
    with pytest.raises(ConfigError) as caught:
        resolve(str(damaged))
    assert "the newest model of run" in str(caught.value) and "(final) cannot be loaded: model.zip is empty" in str(
        caught.value
    )
    assert str(caught.value).endswith(f"pass --policy {damaged / 'checkpoints' / 'step_000000000100' / 'model.zip'}")
    (damaged / "checkpoints" / "step_000000000100" / "model.zip").write_bytes(b"")
    with pytest.raises(ConfigError) as caught:
        resolve(str(damaged))
    assert str(caught.value).endswith("(final) cannot be loaded: model.zip is empty")  # no older one to offer


def test_a_run_of_the_random_agent_is_scored_with_random_actions(tmp_path):
    folder = tmp_path / "random_run"
    RunFolder(folder).create(load_config({**SHORT, "train": {"agent": "random"}}))
    policy = resolve(str(folder))
    assert (policy.kind, policy.run, policy.record) == ("random", str(folder), {"policy": str(folder)})
    assert policy.config().episode.max_steps == 20


def test_module_callable_is_recorded_by_its_source_and_called_with_the_env(tmp_path, monkeypatch):
    source = tmp_path / "my_agent.py"
    source.write_text(
        "import numpy as np\n"
        "def make(env):\n    return lambda observation: np.zeros(env.action_space.shape, np.float32)\n"
        "def wrong():\n    return None\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    policy = resolve("my_agent:make")
    assert policy.kind == "callable"
    assert policy.record == {
        "policy": "my_agent:make",
        "policy_source_sha256": hashlib.sha256(source.read_bytes()).hexdigest(),
    }
    assert resolve("sys:exit").record == {"policy": "sys:exit"}  # built in: no source file to hash
    env = AnimalAIEnv(config=load_config(SHORT))
    try:
        assert not policy.build(env)(None).any()
        with pytest.raises(
            ConfigError,
            match=r"'my_agent:wrong' could not be called with the environment \(.*\); allowed: a module:callable "
            "that takes the env and returns the policy",
        ):
            resolve("my_agent:wrong").build(env)
    finally:
        env.close()
        sys.modules.pop("my_agent", None)


def test_a_policy_its_caller_makes_is_recorded_by_name_and_not_built_here():
    human = external("human:ada")
    assert (human.kind, human.record) == ("external", {"policy": "human:ada"})
    assert policy_record(human, "list") == {"policy": "human:ada", "seeds": "list", "seed_key": "public"}
    with pytest.raises(ConfigError, match="'human:ada' is made by its caller"):
        human.build(None)
    assert Policy("x", "random") == Policy("x", "random", record={"policy": "x"})  # the record is not its identity


def test_the_policy_keeps_the_string_it_was_given_and_the_trust_it_was_given(run):
    for text in ("random", str(run), str(run / "final" / "model.zip")):
        assert resolve(text).name == text and resolve(text).trust is False
        assert resolve(text, trust=True).trust is True
    assert resolve(str(run / "final" / "model.zip")).record["policy"] == str(run / "final" / "model.zip")


def test_a_model_that_does_not_fit_the_environment_is_refused_naming_both_spaces(run, tmp_path):
    """A model file outside its run folder (nothing to compare its config with) is still checked
    against the environment's spaces, whether loaded without or with code (--trust-model)."""
    bare = tmp_path / "model.zip"
    shutil.copy(run / "final" / "model.zip", bare)
    env = AnimalAIEnv(config=load_config(SHORT))  # 8 rays a side, the model 4
    try:
        for trust in (False, True):
            with pytest.raises(ConfigError) as caught:
                resolve(str(bare), trust=trust).build(env)
            message = str(caught.value)
            assert message.startswith(
                f"--policy: model file {str(bare)!r} does not fit this environment (action mode 'rotation'): "
            )
            assert "observation 'rays'" in message and "(9, " in message and "(17, " in message, message
            assert message.endswith(". Score it with the config it was trained with (--config)")
    finally:
        env.close()


def test_a_trusted_model_acts_as_the_one_read_without_code(run):
    env = AnimalAIEnv(config=resolve(str(run)).config())
    try:
        safe, trusted = resolve(str(run)).build(env), resolve(str(run), trust=True).build(env)
        assert trusted.model.__class__.__name__ == "PPO" and not trusted.recurrent
        observation, _ = env.reset(seed=4)
        for _ in range(5):
            action = safe(observation)
            assert np.array_equal(action, trusted(observation))
            observation, *_ = env.step(action)
    finally:
        env.close()


def test_a_recurrent_model_carries_its_memory_through_an_episode_and_forgets_it_at_reset(tmp_path):
    """As RecurrentPPO itself plays: the state goes from one decision to the next, and a new
    episode starts from none."""
    needs("sb3_contrib", "train")
    from sb3_contrib import RecurrentPPO

    config = load_config(SHORT)
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        model = RecurrentPPO(
            "MultiInputLstmPolicy",
            env,
            n_steps=16,
            batch_size=16,
            seed=0,
            device="cpu",
            policy_kwargs={"net_arch": [8], "lstm_hidden_size": 8},
        )
        path = tmp_path / "lstm.zip"
        model.save(path)
        for trust in (False, True):
            policy = resolve(str(path), trust=trust).build(env)
            assert policy.recurrent
            observation, _ = env.reset(seed=2)  # a fresh policy starts without memory, reset or not
            state, start = None, np.array([True])
            for _ in range(4):
                expected, state = model.predict(observation, state=state, episode_start=start, deterministic=True)
                start = np.array([False])
                assert np.allclose(policy(observation), expected, rtol=0, atol=GRID)  # up to the action grid
                observation, *_ = env.step(expected)
            policy.reset(3)
            assert policy.state is None and policy.start is True
            observation, _ = env.reset(seed=3)
            expected, _ = model.predict(observation, state=None, episode_start=np.array([True]), deterministic=True)
            assert np.allclose(policy(observation), expected, rtol=0, atol=GRID)
    finally:
        env.close()


def test_a_model_ignores_the_observation_keys_its_caller_added(run):
    """aaai show turns the camera on to draw it: the model, trained without it, never sees it."""
    config = load_config({**SHORT, "sensors": {"rays_per_side": 4, "camera": True, "camera_resolution": 16}})
    env = AnimalAIEnv(config=config)
    try:
        with pytest.raises(ConfigError, match="sensors.camera: model False, environment True"):
            resolve(str(run)).build(env)
        policy = resolve(str(run)).build(env, extra_keys=("camera",))
        observation, _ = env.reset(seed=1)
        assert "camera" in observation
        plain = {k: v for k, v in observation.items() if k != "camera"}
        assert np.array_equal(policy(observation), on_grid(policy.model.predict(plain, deterministic=True)[0]))
    finally:
        env.close()


def _rllib_run(folder: Path) -> Path:
    """A run folder as ``aaai train --backend rllib`` leaves it (the checkpoint's files stand-ins)."""
    RunFolder(folder).create(load_config(SHORT))
    module = folder / "final" / "rllib" / "learner_group" / "learner" / "rl_module" / "default_policy"
    module.mkdir(parents=True)
    (module / "module_state.pkl").write_bytes(b"weights")
    (folder / "final" / "rllib" / "algorithm_state.pkl").write_bytes(b"state")
    (folder / "final" / "state.json").write_text(json.dumps({"step": 10, "curriculum": {}}))
    return folder / "final" / "rllib"


def test_an_rllib_run_is_named_by_its_checkpoint_and_the_hash_of_its_files(tmp_path):
    checkpoint = _rllib_run(tmp_path / "run")
    policy = resolve(str(tmp_path / "run"))
    assert (policy.name, policy.kind, policy.file, policy.run) == (
        str(tmp_path / "run"),
        "rllib",
        str(checkpoint),
        str(tmp_path / "run"),
    )
    assert policy.config().episode.max_steps == 20
    digest = hashlib.sha256()  # over each file's path, a NUL and its own SHA-256, in path order
    for name in ("algorithm_state.pkl", "learner_group/learner/rl_module/default_policy/module_state.pkl"):
        digest.update(name.encode() + b"\0" + hashlib.sha256((checkpoint / name).read_bytes()).hexdigest().encode())
    assert policy.record == {
        "policy": str(tmp_path / "run"),
        "model": str(checkpoint),
        "model_sha256": digest.hexdigest(),
    }
    assert resolve(str(tmp_path / "run"), trust=True).trust is True
    (checkpoint / "algorithm_state.pkl").write_bytes(b"changed")
    assert resolve(str(tmp_path / "run")).record["model_sha256"] != digest.hexdigest()


def test_an_rllib_checkpoint_from_elsewhere_is_refused_before_it_loads(tmp_path):
    needs("ray.rllib", "ray")
    _rllib_run(tmp_path / "run")
    env = AnimalAIEnv(config=load_config(SHORT))
    try:
        with pytest.raises(ConfigError, match=r"RLlib checkpoint '.*final/rllib' is made of pickles"):
            resolve(str(tmp_path / "run")).build(env)
    finally:
        env.close()


def test_the_trust_given_with_a_string_reaches_every_kind_of_policy(tmp_path, monkeypatch):
    from aaai.scoring.policies import as_policy, factory

    source = tmp_path / "trusting_agent.py"
    source.write_text("def make(env):\n    return None\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        for text in ("random", "trusting_agent:make"):
            assert as_policy(text, trust=True).trust is True and as_policy(text).trust is False
        assert resolve("trusting_agent:make").record["policy_source_sha256"]
    finally:
        sys.modules.pop("trusting_agent", None)
    folder = tmp_path / "random_run"
    RunFolder(folder).create(load_config({**SHORT, "train": {"agent": "random"}}))
    assert resolve(str(folder), trust=True).trust is True and resolve(str(folder)).name == str(folder)
    assert as_policy(resolve("gait")) == resolve("gait")
    import os.path

    assert factory("os:path.join") is os.path.join  # a dotted attribute path


def test_a_model_missing_a_part_of_the_environment_is_refused_naming_both_sides(run, tmp_path):
    bare = tmp_path / "model.zip"
    shutil.copy(run / "final" / "model.zip", bare)
    camera = AnimalAIEnv(config=load_config({"sensors": {"rays_per_side": 4, "camera": True, "camera_resolution": 16}}))
    gait = AnimalAIEnv(config=load_config({"sensors": {"rays_per_side": 4}, "agent": {"action_mode": "gait"}}))
    try:
        for trust in (False, True):
            with pytest.raises(ConfigError) as caught:
                resolve(str(bare), trust=trust).build(camera)
            assert "observation 'camera': model absent, environment Box(" in str(caught.value)
            with pytest.raises(ConfigError) as caught:
                resolve(str(bare), trust=trust).build(gait)
            assert "(action mode 'gait')" in str(caught.value) and "action space: model Box(" in str(caught.value)
    finally:
        camera.close()
        gait.close()


def test_a_model_stable_baselines3_cannot_read_is_named_when_trusted(tmp_path):
    import zipfile

    path = tmp_path / "odd.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", "{not json")
        archive.writestr("policy.pth", b"nothing")
    env = AnimalAIEnv(config=load_config(SHORT))
    try:
        message = rf"model file '{path}' cannot be loaded by stable-baselines3: \w+Error: "
        with pytest.raises(ConfigError, match=message):
            resolve(str(path), trust=True).build(env)
    finally:
        env.close()


def test_sensor_settings_count_only_for_senses_that_are_on():
    """The ray settings of a model are compared only when the rays are on on one side; a setting
    one side does not have at all is named as absent."""
    rays_off = {"sensors": {"rays": False, "camera": False}}
    env = AnimalAIEnv(config=load_config(rays_off))
    try:
        trained = load_config({"sensors": {"rays": False, "camera": False, "ray_length": 3.0}})
        check_model(Path("m.zip"), env, (), trained)  # the rays are off on both sides
        check_model(Path("m.zip"), env, ("rays",), load_config({"sensors": {"rays": True, "camera": False}}))
        with pytest.raises(ConfigError, match="sensors.rays: model True, environment False"):
            check_model(Path("m.zip"), env, (), load_config({"sensors": {"rays": True, "camera": False}}))
        older = json.loads(json.dumps(load_config(rays_off).to_dict()))
        older["sensors"]["retired_sense"] = 1
        with pytest.raises(ConfigError, match=r"sensors.retired_sense: model 1, environment 'absent'"):
            check_model(Path("m.zip"), env, (), older)
    finally:
        env.close()
    on = AnimalAIEnv(config=load_config({"sensors": {"rays_per_side": 4}}))
    try:
        with pytest.raises(ConfigError, match=r"sensors.ray_length: model 3.0, environment "):
            check_model(Path("m.zip"), on, (), load_config({"sensors": {"rays_per_side": 4, "ray_length": 3.0}}))
    finally:
        on.close()


def test_aaai_eval_scores_a_checkpoint_file_with_its_runs_senses(run, tmp_path):
    """docs (Training): an earlier point of a run is scored with --policy RUN/checkpoints/step_…/model.zip,
    no --config needed: the run's senses (4 rays a side, not the default 8) come with it."""
    from click.testing import CliRunner

    from aaai_cli.main import cli

    model = run / "checkpoints" / "step_000000000100" / "model.zip"
    out = tmp_path / "board.csv"
    args = ["eval", "--policy", str(model), "--levels", "0", "--difficulty", "0", "--seeds", "1", "--out", str(out)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert len(out.read_text().splitlines()) == 2  # the header and one episode
    record = json.loads(out.with_name("board_scored_with.json").read_text())
    assert '"rays_per_side": 4' in json.dumps(record)  # scored with the run's senses


def test_aaai_run_plays_a_run_and_its_checkpoint_with_the_runs_senses(run):
    from click.testing import CliRunner

    from aaai_cli.main import cli

    for policy in (run, run / "checkpoints" / "step_000000000100" / "model.zip"):
        args = ["run", "--policy", str(policy), "--levels", "0", "--difficulty", "0", "--episodes", "1"]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 0, result.output


def test_aaai_show_films_a_run_with_the_runs_senses(run, tmp_path):
    from click.testing import CliRunner

    from aaai_cli.main import cli

    video = tmp_path / "run.mp4"
    args = ["show", "0", "--policy", str(run), "--video", str(video), "--steps", "5"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert video.stat().st_size > 0


def test_a_model_file_of_a_run_whose_config_is_broken_is_refused_naming_it(run, tmp_path):
    broken = tmp_path / "broken_run"
    shutil.copytree(run, broken)
    (broken / "config.yaml").write_text("level: 50\n")
    with pytest.raises(ConfigError, match=r"belongs to run '.*broken_run', whose config cannot be read \(.*level"):
        resolve(str(broken / "final" / "model.zip"))
    elsewhere = tmp_path / "broken_run" / "notes" / "model.zip"  # not a run's saved point: no run config
    elsewhere.parent.mkdir()
    shutil.copy(broken / "final" / "model.zip", elsewhere)
    assert resolve(str(elsewhere)).run_config is None
