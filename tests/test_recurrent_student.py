"""The recurrent student (train.student_policy: lstm): DAgger over whole episodes with sb3-contrib's
RecurrentPPO policy, its memory carried through each scored episode and forgotten at the next."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from conftest import needs

needs("sb3_contrib", "train")

from aaai.config import env_part, load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.scoring.episodes import play  # noqa: E402
from aaai.scoring.model_archive import read_archive  # noqa: E402
from aaai.scoring.model_io import policy_class_name  # noqa: E402
from aaai.scoring.policies import resolve  # noqa: E402
from aaai.train.recurrent_student import RecurrentActor, fit_sequences, fit_shuffled_chunks  # noqa: E402
from aaai.train.student import train_student  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

TINY_LSTM = {
    "agent": {"action_mode": "gait"},
    "curriculum": {"levels": "0", "difficulties": "0-1"},
    "train": {
        "teacher": "reference",
        "student_policy": "lstm",
        "dagger_sequence": 16,
        "num_envs": 1,
        "net_width": 16,
        "dagger_iterations": 2,
        "dagger_episodes": 2,
        "dagger_epochs": 2,
        "dagger_episode_cap": 40,
    },
}


@pytest.fixture(scope="module")
def lstm_run(tmp_path_factory):
    """One tiny recurrent student, shared by the tests below."""
    run = tmp_path_factory.mktemp("lstm") / "student"
    result = train_student(run, load_config(TINY_LSTM), say=lambda message: None)
    assert result.episodes == 4
    return run


def _write(folder, data) -> str:
    path = folder / "config.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_a_recurrent_student_is_saved_as_recurrent_ppo_and_scored_by_eval_without_unpickling(
    lstm_run, tmp_path, monkeypatch
):
    import pickle

    import cloudpickle

    assert policy_class_name(read_archive(lstm_run / "final" / "model.zip")) == "RecurrentMultiInputActorCriticPolicy"

    def refuse(*args, **kwargs):
        raise AssertionError("a model file was unpickled")

    monkeypatch.setattr(pickle, "loads", refuse)
    monkeypatch.setattr(cloudpickle, "loads", refuse)
    out = tmp_path / "scores.csv"
    scored = CliRunner().invoke(
        cli, ["eval", "--policy", str(lstm_run), "--levels", "0", "--difficulty", "0", "-k", "2", "--out", str(out)]
    )
    assert scored.exit_code == 0, scored.output
    assert len(out.read_text().splitlines()) == 3


def test_scoring_carries_the_hidden_state_through_an_episode_and_resets_it_at_the_next(lstm_run):
    """The same observation gets another action after a history; a reset gives the first one again."""
    policy = resolve(str(lstm_run)).build(env := AnimalAIEnv(config=resolve(str(lstm_run)).play_config()))
    try:
        assert policy.recurrent
        first, _ = env.reset(seed=5, options={"level": 0, "difficulty": 1})
        policy.reset(5)
        start = policy(first)
        observation = first
        for _ in range(6):
            observation, *_ = env.step(policy(observation))
        assert not np.array_equal(policy(first), start)  # the same observation, after a history
        policy.reset(5)
        assert np.array_equal(policy(first), start)  # forgotten at the episode's start
        # The episode loop of eval, run and show resets it: the same episode twice, the same steps.
        ends = [play(env, policy, 5, options={"level": 0, "difficulty": 1}, max_steps=12) for _ in range(2)]
        assert ends[0].episode_return == ends[1].episode_return
        assert all(np.array_equal(ends[0].observation[k], ends[1].observation[k]) for k in ends[0].observation)
    finally:
        env.close()


def test_demos_and_ray_tasks_reset_the_memory_between_episodes(lstm_run):
    """A Minari recording and a Ray worker (which keeps its policy from task to task) play each
    episode from a fresh memory: an episode played after another is the episode played alone."""
    needs("minari", "demos")
    from aaai.scoring.demos import record_episode
    from aaai.scoring.distributed import _WORKER, _worker_env_and_policy

    chosen = resolve(str(lstm_run))
    config = load_config(chosen.config(), episode={"max_steps": 15})
    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        policy = chosen.build(env)
        alone = record_episode(env, policy, 0, 1, 5, 0)
        record_episode(env, policy, 0, 0, 6, 1)
        again = record_episode(env, policy, 0, 1, 5, 2)
        assert np.array_equal(alone.actions, again.actions)
    finally:
        env.close()
    model = [(lstm_run / "final" / "model.zip").read_bytes()]
    ends = []
    try:
        for seed, difficulty in ((5, 1), (6, 0), (5, 1)):  # one Ray task each, in one worker process
            worker_env, acting = _worker_env_and_policy(chosen, model, config)
            ends.append(play(worker_env, acting, seed, options={"level": 0, "difficulty": difficulty}))
    finally:
        _WORKER.pop("env").close()
        _WORKER.clear()
    assert all(np.array_equal(ends[0].observation[k], ends[2].observation[k]) for k in ends[0].observation)


def test_init_from_a_recurrent_student_fine_tunes_it_with_recurrent_ppo(lstm_run, tmp_path):
    tuned = tmp_path / "tuned"
    config = _write(tmp_path, {"train": {"net_width": 16, "n_steps": 32, "batch_size": 32, "n_epochs": 1}})
    args = ["train", "--init-from", str(lstm_run), "--action-mode", "gait", "--levels", "0", "--difficulty", "0"]
    result = CliRunner().invoke(cli, args + ["--steps", "32", "--envs", "1", "--run", str(tuned), "--config", config])
    assert result.exit_code == 0, result.output
    assert policy_class_name(read_archive(tuned / "final" / "model.zip")) == "RecurrentMultiInputActorCriticPolicy"
    rllib = CliRunner().invoke(cli, args + ["--backend", "rllib", "--run", str(tmp_path / "rllib")])
    assert rllib.exit_code == 2 and "--init-from: got" in rllib.output and "--backend sb3" in rllib.output
    assert not (tmp_path / "rllib").exists()


def test_a_student_policy_that_is_not_allowed_is_refused_in_one_line(tmp_path):
    tiny = {"dagger_iterations": 1, "dagger_episodes": 1, "dagger_episode_cap": 5, "num_envs": 1}  # if not refused
    bad = _write(tmp_path, {"train": {"teacher": "reference", "student_policy": "gru", **tiny}})
    refused = CliRunner().invoke(cli, ["train", "--config", bad, "--levels", "0", "--run", str(tmp_path / "s")])
    assert refused.exit_code == 2 and "Traceback" not in refused.output
    assert "config key 'train.student_policy': got 'gru'; allowed: one of mlp, lstm" in refused.output, refused.output
    ppo = _write(tmp_path, {"train": {"student_policy": "lstm"}})
    refused = CliRunner().invoke(cli, ["train", "--config", ppo, "--steps", "64", "--run", str(tmp_path / "p")])
    assert refused.exit_code == 2 and "'train.student_policy': got 'lstm' for a PPO run" in refused.output
    assert not (tmp_path / "s").exists() and not (tmp_path / "p").exists()
    capped = _write(
        tmp_path, {"train": {"teacher": "reference", "student_policy": "lstm", "dagger_max_decisions": 99, **tiny}}
    )
    refused = CliRunner().invoke(cli, ["train", "--config", capped, "--levels", "0", "--run", str(tmp_path / "c")])
    assert refused.exit_code == 2 and "'train.dagger_max_decisions': got 99; allowed with" in refused.output
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("chunks", ["shuffled", "episodes"])
@pytest.mark.parametrize("actions", ["commands", "choices"])
def test_backpropagation_through_time_carries_the_memory_across_chunks(chunks, actions):
    """A cue seen only at an episode's first decision is the label of all of its 12: learnable only
    if the hidden state is carried from one chunk of 4 decisions into the next (train.dagger_chunks
    shuffled: from the state its episode gives a chunk; episodes: chunk after chunk), and reset
    between episodes (the cue of one episode says nothing of the next's). The label is a command
    (regressed) or a choice of 3 (agent.action_mode discrete: classified)."""
    import torch
    from gymnasium import spaces

    from aaai.train.recurrent_student import build_policy

    torch.manual_seed(0)
    observation_space = spaces.Dict({"x": spaces.Box(-1.0, 1.0, (2,), np.float32)})
    choices = actions == "choices"
    action_space = spaces.MultiDiscrete([3]) if choices else spaces.Box(-1.0, 1.0, (1,), np.float32)
    policy = build_policy(observation_space, action_space, 16)
    cues = np.random.default_rng(0).choice([-1.0, 1.0], size=48).astype(np.float32)
    x = np.zeros((48, 12, 2), np.float32)
    x[:, 0, 0], x[:, 0, 1] = cues, 1.0  # the cue, and "an episode starts here"
    labels = np.repeat(cues + 1.0 if choices else cues, 12)[:, None]  # choice 0 or 2
    starts = np.tile(np.arange(12) == 0, 48)
    fitter = fit_shuffled_chunks if chunks == "shuffled" else fit_sequences
    loss = fitter(policy, {"x": x.reshape(-1, 2)}, labels, starts, 60, 0, 4, 2e-2, 48 * 4)
    # without the memory across chunks, 8 of 12 labels are a coin toss: 0.67, or a cross-entropy of 0.46
    assert loss < 0.1, loss
    actor = RecurrentActor(policy)
    for cue in (1.0, -1.0):  # the memory as it acts: the cue's sign to the end of the episode
        actor.reset()
        played = [actor({"x": np.array([cue, 1.0] if t == 0 else [0.0, 0.0], np.float32)}) for t in range(12)]
        side = [int(a[0]) - 1 if choices else np.sign(a[0]) for a in played[8:]]
        assert side == [cue] * 4, played


def test_a_run_starts_from_another_runs_rounds_and_refits_on_them_without_playing(lstm_run, tmp_path):
    """train.dagger_data_from: the student is fitted on the other run's saved rounds (the first
    dagger_iterations of them), nothing is played, the run ends with a final model that eval scores;
    a run of other senses is refused in one line, before anything is written."""
    import csv

    config = dict(TINY_LSTM, train={**TINY_LSTM["train"], "dagger_epochs": 1})
    refit = tmp_path / "refit"
    args = ["train", "--config", _write(tmp_path, config), "--data-from", str(lstm_run), "--run", str(refit)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(refit / "dagger.csv")))
    source_rows = list(csv.DictReader(open(lstm_run / "dagger.csv")))
    assert [(r["iteration"], r["episodes"], r["dataset"]) for r in rows] == [("1", "0", source_rows[-1]["dataset"])]
    assert sorted(p.name for p in (refit / "dagger").iterdir()) == ["iteration_000.npz", "iteration_001.npz"]
    assert (refit / "final" / "model.zip").is_file() and len((refit / "episodes.csv").read_text().splitlines()) == 1
    scored = CliRunner().invoke(cli, ["eval", "--policy", str(refit), "--levels", "0", "--difficulty", "0", "-k", "1"])
    assert scored.exit_code == 0, scored.output
    other = dict(config, sensors={"rays_per_side": 3})
    other_run = tmp_path / "other"
    refused = CliRunner().invoke(
        cli, ["train", "--config", _write(tmp_path, other), "--data-from", str(lstm_run), "--run", str(other_run)]
    )
    assert refused.exit_code == 2 and "Traceback" not in refused.output
    assert "'train.dagger_data_from': got" in refused.output and "whose sensors differs" in refused.output
    ppo = CliRunner().invoke(cli, ["train", "--steps", "64", "--data-from", str(lstm_run), "--run", str(other_run)])
    assert ppo.exit_code == 2 and "'train.dagger_data_from': got" in ppo.output and "for a PPO run" in ppo.output
    assert not other_run.exists()


@pytest.mark.parametrize("chunks", ["shuffled", "episodes", "mlp"])
def test_a_refits_step_size_falls_to_the_configured_end_along_a_cosine(chunks, monkeypatch):
    """train.dagger_learning_rate_end: the first step of a refit at 0.001, the last at the end, in
    between falling; without it every step at 0.001 (the recurrent student's two ways of stepping,
    and the stateless student's)."""
    import torch
    from gymnasium import spaces

    from aaai.train.recurrent_student import build_policy

    sizes: list[float] = []
    step = torch.optim.Adam.step

    def spy(self, *args, **kwargs):
        sizes.append(self.param_groups[0]["lr"])
        return step(self, *args, **kwargs)

    monkeypatch.setattr(torch.optim.Adam, "step", spy)
    observation_space = spaces.Dict({"x": spaces.Box(-1.0, 1.0, (2,), np.float32)})
    policy = build_policy(observation_space, spaces.Box(-1.0, 1.0, (1,), np.float32), 8)
    x, labels, starts = np.zeros((40, 2), np.float32), np.zeros((40, 1), np.float32), np.arange(40) % 10 == 0
    fitter = fit_shuffled_chunks if chunks == "shuffled" else fit_sequences
    if chunks == "mlp":  # 40 decisions in batches of 10
        from aaai.train import student

        monkeypatch.setattr(student, "BATCH_SIZE", 10)
        policy = student.build_policy(observation_space, spaces.Box(-1.0, 1.0, (1,), np.float32), 8)

        def fitter(policy, observations, labels, starts, epochs, seed, *_, final_learning_rate=None):
            return student.fit(policy, observations, labels, epochs, seed, final_learning_rate)

    fitter(policy, {"x": x}, labels, starts, 3, 0, 5, 1e-3, 10, final_learning_rate=1e-5)
    assert len(sizes) == 3 * 4 and sizes[0] == pytest.approx(1e-3) and sizes[-1] == pytest.approx(1e-5)
    assert all(a >= b for a, b in zip(sizes, sizes[1:])) and 1e-5 < sizes[6] < 1e-3
    sizes.clear()
    fitter(policy, {"x": x}, labels, starts, 2, 0, 5, 1e-3, 10)
    assert sizes == [pytest.approx(1e-3)] * 8
