"""Golden trajectories: the environment's behaviour, bit for bit, pinned across refactors.

Each case runs a fixed policy from a fixed seed and hashes every observation, reward, reward term,
flag and info value of the episode. A change that alters any of them, however slightly, fails here.
A deliberate change of behaviour rewrites the file with

    python -m tests.test_golden

and the commit says why the trajectories moved.
"""

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from aaai.env import AnimalAIEnv
from aaai.levels import all_levels

GOLDEN = Path(__file__).with_name("golden_trajectories.json")
SENSES = dict(
    rays=True,
    camera=True,
    camera_resolution=16,
    joint_velocities=True,
    head_orientation=True,
    foot_contacts=True,
    shaping=0.1,
    shaping_gamma=0.99,
    limb_food_reward="flat",
)
# (name, level, difficulty, seed, policy, steps): random actions on every level, and the reference
# controller where it eats (yellows on L1, the green on L0) so that food events are covered.
CASES = [(f"random-L{level}", level, 5, 1000 + level, "random", 250) for level in sorted(all_levels())] + [
    ("reference-L0", 0, 0, 7, "reference", 400),
    ("reference-L1", 1, 3, 11, "reference", 1500),
    ("random-L7-dark", 7, 10, 3, "random", 900),
]


def trajectory_digest(level: int, difficulty: int, seed: int, policy: str, steps: int) -> dict:
    env = AnimalAIEnv(level=level, difficulty=difficulty, max_steps=steps, **SENSES)
    digest = hashlib.sha256()
    try:
        observation, info = env.reset(seed=seed)
        if policy == "reference":
            from aaai.task.reference import ReferenceController

            act = ReferenceController(env)
            act.reset(seed)
        else:
            rng = np.random.default_rng(seed)
            act = lambda _: rng.uniform(-1, 1, 8).astype(np.float32)  # noqa: E731

        def feed(observation, info):
            for key in sorted(observation):
                digest.update(key.encode() + np.ascontiguousarray(observation[key]).tobytes())
            digest.update(json.dumps(info, sort_keys=True, default=float).encode())

        feed(observation, info)
        total, ended, dark = 0.0, None, 0
        for step in range(steps):
            observation, reward, terminated, truncated, info = env.step(act(observation))
            digest.update(np.float64(reward).tobytes() + bytes([terminated, truncated]))
            feed(observation, info)
            total += reward
            dark += info["dark"]
            if terminated or truncated:
                ended = step + 1
                break
        return {
            "sha256": digest.hexdigest(),
            "return": round(total, 6),
            "steps": ended,
            "food_eaten": info["food_eaten"],
            "dark_steps": dark,
        }
    finally:
        env.close()


@pytest.mark.parametrize("name, level, difficulty, seed, policy, steps", CASES, ids=[c[0] for c in CASES])
def test_trajectory_is_unchanged(name, level, difficulty, seed, policy, steps):
    expected = json.loads(GOLDEN.read_text())[name]
    assert trajectory_digest(level, difficulty, seed, policy, steps) == expected


def test_the_cases_cover_eating_and_the_dark():
    golden = json.loads(GOLDEN.read_text())
    assert set(golden) == {case[0] for case in CASES}
    assert golden["reference-L0"]["food_eaten"] >= 1 and golden["reference-L1"]["food_eaten"] >= 2
    assert golden["random-L7-dark"]["dark_steps"] > 0


if __name__ == "__main__":
    results = {case[0]: trajectory_digest(*case[1:]) for case in CASES}
    GOLDEN.write_text(json.dumps(results, indent=1) + "\n")
    print(json.dumps(results, indent=1), file=sys.stderr)
