"""A camera student's decision against a ray student's: the senses, the network's forward pass, the refit.

Two students as DAgger's workers run them (aaai.train.student): the ray student of
configs/student.yaml (33 rays in two fans with their memory, the training senses, a 256 x 256
MultiInputPolicy) and the camera student of configs/student_camera.yaml (a 64 px colour image, no
rays, the same network behind NatureCNN), each with freshly made weights (the cost does not depend
on them). Each round, each student (the order rotated) plays ``--decisions`` decisions of one
level (the levels taken in turn, round by round, on one seed, reset untimed when an episode ends);
a decision is ``env.step`` of a fixed random action and the student's forward pass on the
observation (``policy.predict``, one thread, float32). Timed inside it: the senses (the rays'
``rayTestBatch`` and memory, or the camera's TinyRenderer image), the forward pass, and the rest of
the step (physics, gait). Then, alternated the same way, one refit batch of 1,024 labelled
decisions for each (forward, loss, backward, Adam; aaai.train.student.fit), from random data.

Reported: the median over the rounds of each figure, in ms, with its spread (min..max), and the
per-round ratio camera / rays; the load average before and after. Writes bench/camera_student.md
and bench/camera_student.json.

    nice -n 10 .venv/bin/python bench/camera_student.py --rounds 7 --decisions 200
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from aaai.config import env_part, load_config
from aaai.env import AnimalAIEnv
from aaai.files import write_atomic
from aaai.tools.rounds import WARM_UP, alternate, load, per_round, summary
from aaai.train.camera_student import seen_space
from aaai.train.student import BATCH_SIZE, LEARNING_RATE, build_policy, mean_actions
from aaai.train.training import with_proprioception

ROOT = Path(__file__).resolve().parents[1]
STUDENTS = {"rays": ROOT / "configs" / "student.yaml", "camera": ROOT / "configs" / "student_camera.yaml"}
PARTS = ("decision", "senses", "forward", "rest")
LEVELS = list(range(12))


class Timed:
    """Wraps ``owner.name`` so that the seconds it spends add up in ``self.seconds``."""

    def __init__(self, owner, name: str):
        self.seconds, inner = 0.0, getattr(owner, name)

        def wrapper(*args, **kwargs):
            started = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - started

        setattr(owner, name, wrapper)


class Student:
    """One student's decisions: its environment, its network, its timers; each call plays a chunk."""

    def __init__(self, path: Path, decisions: int):
        config = with_proprioception(load_config(path))
        self.env = AnimalAIEnv(config=env_part(config, 0.0))
        self.policy = build_policy(
            seen_space(self.env.observation_space), self.env.action_space, config.train.net_width
        )
        self.policy.set_training_mode(False)
        senses = self.env.senses
        self.sense_timers = [Timed(part, "observe") for part in (senses.rays, senses.camera) if part is not None]
        if senses.memory is not None:
            self.sense_timers.append(Timed(senses.memory, "recall"))
        self.decisions, self.round = decisions, 0
        self.actions = np.random.default_rng(0).uniform(-1, 1, (decisions, *self.env.action_space.shape))
        self.parts: dict[str, list[float]] = {part: [] for part in PARTS}

    def __call__(self, decisions: int | None = None) -> float:
        env, policy = self.env, self.policy
        level = LEVELS[self.round % len(LEVELS)]
        observation, _ = env.reset(seed=1, options={"level": level, "difficulty": 5})
        for timer in self.sense_timers:
            timer.seconds = 0.0
        step = forward = 0.0
        count = decisions or self.decisions
        for action in self.actions[:count]:
            started = time.perf_counter()
            policy.predict(observation, deterministic=True)
            between = time.perf_counter()
            observation, _, terminated, truncated, _ = env.step(action.astype(np.float32))
            ended = time.perf_counter()
            forward, step = forward + between - started, step + ended - between
            if terminated or truncated:
                observation, _ = env.reset(seed=1, options={"level": level, "difficulty": 5})
        if decisions is None:  # a timed round (the warm-up is not recorded)
            senses = sum(timer.seconds for timer in self.sense_timers)
            for part, seconds in zip(PARTS, (step + forward, senses, forward, step - senses)):
                self.parts[part].append(1000 * seconds / count)
            self.round += 1
        return count / (step + forward)

    def close(self) -> None:
        self.env.close()


class Refit:
    """One refit batch of random labelled decisions, as aaai.train.student.fit takes them."""

    def __init__(self, student: Student):
        env = student.env
        self.policy = build_policy(seen_space(env.observation_space), env.action_space, student.policy.net_arch[0])
        space = seen_space(env.observation_space)
        rng = np.random.default_rng(0)
        self.batch = {
            key: torch.as_tensor(
                rng.integers(0, 256, (BATCH_SIZE, *sub.shape), dtype=np.uint8)
                if sub.dtype == np.uint8
                else rng.random((BATCH_SIZE, *sub.shape), dtype=np.float32)
            )
            for key, sub in space.spaces.items()
        }
        self.targets = torch.zeros((BATCH_SIZE, *env.action_space.shape))
        self.optimizer = torch.optim.Adam(self.policy.parameters(), lr=LEARNING_RATE)
        self.ms: list[float] = []

    def __call__(self, _: int | None = None) -> float:
        started = time.perf_counter()
        loss = torch.nn.functional.mse_loss(mean_actions(self.policy, self.batch), self.targets)
        self.optimizer.zero_grad()
        loss.backward()
        self.optimizer.step()
        seconds = time.perf_counter() - started
        if _ is None:
            self.ms.append(1000 * seconds / BATCH_SIZE)
        return BATCH_SIZE / seconds


def _fmt(values: list[float], digits: int = 3) -> str:
    s = summary(values)
    return f"{s['median']:.{digits}f} ({s['min']:.{digits}f}..{s['max']:.{digits}f})"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--decisions", type=int, default=200, help="decisions a student plays a round")
    parser.add_argument("--out", default=str(ROOT / "bench"))
    args = parser.parse_args()
    torch.set_num_threads(1)
    before = load()
    students = {name: Student(path, args.decisions) for name, path in STUDENTS.items()}
    try:
        for student in students.values():
            student(WARM_UP)
        alternate({name: student for name, student in students.items()}, args.rounds)
        refits = {name: Refit(student) for name, student in students.items()}
        for refit in refits.values():
            refit(1)
        alternate({name: refit for name, refit in refits.items()}, args.rounds)
    finally:
        for student in students.values():
            student.close()
    after = load()
    rays, camera = students["rays"].parts, students["camera"].parts
    result = {
        "when": time.strftime("%Y-%m-%dT%H:%M", time.gmtime()),
        "rounds": args.rounds,
        "decisions": args.decisions,
        "load": {"before": before, "after": after},
        "ms_per_decision": {name: {part: summary(s.parts[part]) for part in PARTS} for name, s in students.items()},
        "camera_over_rays": {part: summary(per_round(camera[part], rays[part])) for part in PARTS},
        "refit_ms_per_decision": {name: summary(refit.ms) for name, refit in refits.items()},
        "refit_camera_over_rays": summary(per_round(refits["camera"].ms, refits["rays"].ms)),
    }
    out = Path(args.out)
    write_atomic(out / "camera_student.json", json.dumps(result, indent=1) + "\n")
    names = {
        "decision": "a decision (env.step + forward)",
        "senses": "the senses (rays and memory / camera image)",
        "forward": "the network's forward pass (predict)",
        "rest": "the rest of the step (physics, gait)",
    }
    lines = [
        "# A camera student's decision against a ray student's",
        "",
        f"`bench/camera_student.py --rounds {args.rounds} --decisions {args.decisions}`, {result['when']} UTC; "
        f"load {before} -> {after}. Median over the alternated rounds (min..max), ms a decision; one thread, "
        "float32, as DAgger's workers act. Rays: configs/student.yaml (33 rays x 2 fans, memory, MLP 256 x 256); "
        "camera: configs/student_camera.yaml (64 px RGB, NatureCNN, the same MLP).",
        "",
        "| ms a decision | ray student | camera student | camera / rays (per round) |",
        "|---|---:|---:|---:|",
    ]
    for part in PARTS:
        ratio = _fmt(per_round(camera[part], rays[part]), 2)
        lines.append(f"| {names[part]} | {_fmt(rays[part])} | {_fmt(camera[part])} | {ratio} |")
    lines.append(
        f"| refit, per labelled decision and pass (batches of {BATCH_SIZE}) | {_fmt(refits['rays'].ms)} | "
        f"{_fmt(refits['camera'].ms)} | {_fmt(per_round(refits['camera'].ms, refits['rays'].ms), 2)} |"
    )
    write_atomic(out / "camera_student.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
