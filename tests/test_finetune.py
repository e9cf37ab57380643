"""PPO from a student's weights (aaai.train.finetune): the value warm-up moves only the value head,
the anchor's weight follows its schedule, and a heavy anchor holds the policy at the student.

The learner is stable-baselines3's PPO on a small Dict-observation environment without physics, so
that each check takes a fraction of a second; the run's wiring (config keys, refusals) is checked on
aaai's own config."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="needs the train extra (torch)")
sb3 = pytest.importorskip("stable_baselines3", reason="needs the train extra (stable-baselines3)")

from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai.train.finetune import StudentAnchor, anchor_from_config, bc_weight, check_finetune  # noqa: E402
from aaai.train.training import train  # noqa: E402


class Target(gym.Env):
    """Reward for an action near a fixed target (which the started policy does not take): PPO moves
    the policy's mean towards it within a few updates."""

    observation_space = gym.spaces.Dict({"x": gym.spaces.Box(-1.0, 1.0, (3,), np.float32)})
    action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self):
        self.rng = np.random.default_rng(0)
        self.t = 0

    def _observe(self):
        return {"x": self.rng.uniform(-1, 1, 3).astype(np.float32)}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self._observe(), {}

    def step(self, action):
        self.t += 1
        reward = -float(np.abs(np.asarray(action) - 0.8).sum()) / 8
        return self._observe(), reward, False, self.t >= 16, {}


FIXED = {"x": torch.as_tensor(np.random.default_rng(1).uniform(-1, 1, (64, 3)).astype(np.float32))}


def ppo(seed: int = 0, env: type[gym.Env] = Target):
    return sb3.PPO(
        "MultiInputPolicy",
        DummyVecEnv([env]),
        n_steps=32,
        batch_size=16,
        n_epochs=4,
        learning_rate=1e-2,
        gamma=0.5,  # returns hardly depend on the step of the episode, which the observation does not show
        policy_kwargs={"net_arch": [16, 16]},
        seed=seed,
        device="cpu",
    )


def outputs(model):
    """The policy's mean actions, log std and values on fixed observations."""
    with torch.no_grad():
        distribution = model.policy.get_distribution(FIXED).distribution
        return (
            distribution.mean.numpy().copy(),
            distribution.stddev.numpy().copy(),
            model.policy.predict_values(FIXED).numpy().copy(),
        )


def test_value_warmup_moves_only_the_value_head():
    model = ppo()
    mean, std, values = outputs(model)
    model.learn(96, callback=StudentAnchor(None, warmup_steps=96, warmup_epochs=3))
    mean_after, std_after, values_after = outputs(model)
    np.testing.assert_array_equal(mean_after, mean)  # the policy did not move
    np.testing.assert_array_equal(std_after, std)
    assert np.abs(values_after - values).max() > 0.1  # the value head learned the returns (about -3)
    assert model.n_epochs == 4  # PPO's own epochs after the warm-up
    assert all(p.requires_grad for p in model.policy.parameters())  # nothing left frozen


def test_the_value_error_falls_during_the_warmup_and_ppo_moves_after_it():
    model = ppo()
    mean, _, _ = outputs(model)
    errors: list[float] = []
    anchor = StudentAnchor(None, warmup_steps=160, warmup_epochs=20)
    record = anchor._on_rollout_end

    def on_rollout_end():
        record()
        buffer = model.rollout_buffer
        errors.append(float(((buffer.returns - buffer.values) ** 2).mean()))

    anchor._on_rollout_end = on_rollout_end  # type: ignore[method-assign]
    model.learn(224, callback=anchor)
    assert errors[4] < errors[0] / 4  # the fifth rollout's returns, new to the value head, fit far better
    assert np.abs(outputs(model)[0] - mean).max() > 1e-3  # after the warm-up, PPO updates the policy


@pytest.mark.parametrize(
    ("step", "weight"),
    [(0, 2.0), (100, 2.0), (150, 1.0), (199, 0.02), (200, 0.0), (10**6, 0.0)],
)
def test_the_anchor_falls_linearly_to_zero_after_the_warmup(step, weight):
    assert bc_weight(step, coef=2.0, warmup_steps=100, decay_steps=100) == pytest.approx(weight)


def mean_drift(bc_coef: float) -> float:
    model = ppo(seed=3)
    start, _, _ = outputs(model)
    student = {k: v.clone() for k, v in model.policy.state_dict().items()}
    model.learn(128, callback=StudentAnchor(student, bc_coef=bc_coef, decay_steps=10**6))
    return float(np.abs(outputs(model)[0] - start).mean())


def test_a_heavy_anchor_holds_the_policy_at_the_student():
    free, held = mean_drift(0.0), mean_drift(1e4)
    assert free > 0.05  # PPO alone moves the mean action towards the target
    assert held < free / 5


class Choices(Target):
    """Target with Animal-AI's discrete choices (agent.action_mode: discrete): reward for the last
    choice of each part, which the started policy takes a third of the time."""

    action_space = gym.spaces.MultiDiscrete([3, 3, 2])

    def step(self, action):
        self.t += 1
        reward = float((np.asarray(action) == np.array([2, 2, 1])).sum()) / 3
        return self._observe(), reward, False, self.t >= 16, {}


def choice_drift(bc_coef: float) -> float:
    """How far the choices' probabilities on fixed observations move in 4 updates."""
    model = ppo(seed=3, env=Choices)

    def probabilities():
        with torch.no_grad():
            parts = model.policy.get_distribution(FIXED).distribution
            return torch.cat([part.probs for part in parts], dim=1).numpy().copy()

    start = probabilities()
    student = {k: v.clone() for k, v in model.policy.state_dict().items()}
    model.learn(128, callback=StudentAnchor(student, bc_coef=bc_coef, decay_steps=10**6))
    return float(np.abs(probabilities() - start).mean())


def test_a_heavy_anchor_holds_a_student_of_choices():
    """The KL to the student adds over the parts of a MultiDiscrete action (a Categorical each)."""
    free, held = choice_drift(0.0), choice_drift(1e4)
    assert free > 0.02  # PPO alone moves the choices towards the rewarded ones
    assert held < free / 5


def test_the_anchor_needs_a_policy_to_start_from(tmp_path):
    with pytest.raises(ConfigError, match=r"'train.bc_coef': got 0.5 for a run that starts from no policy"):
        check_finetune(load_config(train={"bc_coef": 0.5}))
    with pytest.raises(ConfigError, match=r"'train.value_warmup_steps': got 2048 .*--init-from"):
        check_finetune(load_config(train={"value_warmup_steps": 2048}))
    check_finetune(load_config(train={"bc_coef": 0.5, "init_from": "runs/student"}))
    assert anchor_from_config(load_config(), None) is None  # ordinary PPO: no callback
    with pytest.raises(
        ConfigError, match="'train.value_warmup_steps': got 20480"
    ):  # aaai train, before its run folder exists
        train(tmp_path / "run", load_config("configs/student_ppo.yaml"))
    assert not (tmp_path / "run").exists()
    anchor = anchor_from_config(load_config("configs/student_ppo.yaml"), {})
    assert anchor is not None and (anchor.warmup_steps, anchor.bc_coef, anchor.decay_steps) == (20480, 1.0, 100000)


@pytest.mark.long  # RecurrentPPO's first update takes about 5 s
def test_the_warmup_fits_a_recurrent_policy_s_value_only_and_the_anchor_refuses_it():
    contrib = pytest.importorskip("sb3_contrib", reason="needs the train extra (sb3-contrib)")
    model = contrib.RecurrentPPO(
        "MultiInputLstmPolicy",
        DummyVecEnv([Target]),
        n_steps=16,
        batch_size=16,
        n_epochs=1,
        policy_kwargs={"net_arch": [16, 16], "lstm_hidden_size": 4},
        seed=0,
        device="cpu",
    )
    before = {k: v.clone() for k, v in model.policy.state_dict().items()}
    model.learn(16, callback=StudentAnchor(None, warmup_steps=16, warmup_epochs=2))
    changed = {k.split(".")[0] for k, v in model.policy.state_dict().items() if not torch.equal(v, before[k])}
    assert changed == {"lstm_critic", "mlp_extractor", "value_net"}
    assert all(
        torch.equal(v, before[k])
        for k, v in model.policy.state_dict().items()
        if "value" not in k and "critic" not in k
    )
    with pytest.raises(ConfigError, match="not built for recurrent policies yet"):
        model.learn(16, callback=StudentAnchor(before, bc_coef=1.0))


@pytest.mark.parametrize("name", ["reward_gait", "reward_senses"])
def test_the_one_hour_reward_recipes_learn_from_reward_alone(name):
    config = load_config(f"configs/{name}.yaml")
    train_ = config.train
    assert (train_.teacher, train_.init_from, train_.bc_coef, train_.value_warmup_steps) == ("none", None, 0.0, 0)
    assert (config.agent.action_mode, config.curriculum.sampler) == ("gait", "uniform")
    assert len(config.curriculum.levels) == 13 and config.curriculum.difficulties == tuple(range(11))
