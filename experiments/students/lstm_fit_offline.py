"""The recurrent student's fit, offline: train and held-out loss of fit settings on a DAgger run's saved data.

    python experiments/students/lstm_fit_offline.py RUN OUT.csv [--share 0.3] [--variants a,b,...]

Reads RUN/dagger/iteration_*.npz (every round the run saved), holds out one episode in ten
(seeded), keeps ``--share`` of the other episodes for fitting, and fits a fresh student (seed 0)
with each variant, on one thread. Each variant's row (fit loss of the last pass, train and held-out
loss of the fitted student over whole episodes, its hidden state carried from each episode's
start, CPU minutes) is appended to OUT.csv as it finishes; a variant already there is skipped, so
the script continues where it stopped. ``mlp`` is the stateless student fitted on the same data.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np
import torch

from aaai.train import recurrent_student, student
from aaai.train.camera_student import Dataset

# name: (student, epochs, sequence, batch decisions, learning rate, final learning rate or None);
# "shuffled": chunks drawn from the whole data, from stored hidden states (fit_shuffled_chunks)
VARIANTS = {
    "shuffled": ("shuffled", 6, 64, 1024, 1e-3, None),
    "shuffled_seq16": ("shuffled", 6, 16, 1024, 1e-3, None),
    "shuffled_cosine18": ("shuffled", 18, 64, 1024, 1e-3, 1e-4),
    "shuffled_seq16_cosine18": ("shuffled", 18, 16, 1024, 1e-3, 1e-4),
    "shuffled_seq128": ("shuffled", 6, 128, 1024, 1e-3, None),
    "shuffled_lr3e-3": ("shuffled", 6, 64, 1024, 3e-3, None),
    "shuffled_epochs18": ("shuffled", 18, 64, 1024, 1e-3, None),
    "shuffled_cosine6": ("shuffled", 6, 64, 1024, 1e-3, 1e-4),
    "current": ("lstm", 6, 64, 1024, 1e-3, None),
    "mlp": ("mlp", 6, 0, 1024, 1e-3, None),
    "epochs18": ("lstm", 18, 64, 1024, 1e-3, None),
    "cosine6": ("lstm", 6, 64, 1024, 1e-3, 1e-4),
    "cosine18": ("lstm", 18, 64, 1024, 1e-3, 1e-4),
    "seq128": ("lstm", 6, 128, 1024, 1e-3, None),
    "seq16": ("lstm", 6, 16, 1024, 1e-3, None),
    "batch256": ("lstm", 6, 64, 256, 1e-3, None),
    "batch4096": ("lstm", 6, 64, 4096, 1e-3, None),
    "lr3e-4": ("lstm", 6, 64, 1024, 3e-4, None),
    "lr3e-3": ("lstm", 6, 64, 1024, 3e-3, None),
    "mlp18": ("mlp", 18, 0, 1024, 1e-3, None),
    "seq32x128": ("lstm", 6, 32, 4096, 1e-3, None),
    "seq16x256": ("lstm", 6, 16, 4096, 1e-3, None),
    "seq16x256_cosine18": ("lstm", 18, 16, 4096, 3e-3, 1e-4),
}


def load(run: Path) -> Dataset:
    data = Dataset()
    rounds = sorted((run / "dagger").glob("iteration_[0-9][0-9][0-9].npz"))
    data.load(run / "dagger", len(rounds))
    return data


def select(data: Dataset, spans: list[tuple[int, int]], episodes: np.ndarray):
    index = np.concatenate([np.arange(*spans[e]) for e in episodes])
    observations = {key: value[index] for key, value in data.observations.items()}
    return observations, data.labels[index], data.starts[index]


def sequence_loss(policy, observations, labels, starts, lanes: int = 64, sequence: int = 256) -> float:
    """Mean squared error per decision of the recurrent student over whole episodes (state from zero at each start)."""
    inputs = {key: torch.as_tensor(value, dtype=torch.float32) for key, value in observations.items()}
    targets = torch.as_tensor(labels, dtype=torch.float32)
    spans = recurrent_student.episode_spans(starts)
    layers, _, hidden = policy.lstm_hidden_state_shape
    total, count = 0.0, 0.0
    with torch.no_grad():
        for first_episode in range(0, len(spans), lanes):
            batch = spans[first_episode : first_episode + lanes]
            begins = torch.tensor([b for b, _ in batch])
            lengths = torch.tensor([e - b for b, e in batch])
            zeros = torch.zeros(layers, len(batch), hidden)
            state: tuple = (zeros, zeros.clone())
            for first in range(0, int(lengths.max()), sequence):
                steps = torch.arange(first, min(first + sequence, int(lengths.max())))
                mask, index = recurrent_student.lane_rows(begins, lengths, steps)
                means, state = recurrent_student.chunk_means(
                    policy, {k: v[index] for k, v in inputs.items()}, state, len(batch)
                )
                errors = ((means - targets[index]) ** 2).mean(dim=-1)
                total, count = total + float((errors * mask).sum()), count + float(mask.sum())
    return total / count


def flat_loss(policy, observations, labels) -> float:
    inputs = {key: torch.as_tensor(value, dtype=torch.float32) for key, value in observations.items()}
    targets = torch.as_tensor(labels, dtype=torch.float32)
    total = 0.0
    with torch.no_grad():
        for first in range(0, len(targets), 4096):
            batch = {k: v[first : first + 4096] for k, v in inputs.items()}
            total += float(((student.mean_actions(policy, batch) - targets[first : first + 4096]) ** 2).sum())
    return total / targets.numel()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("run", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--share", type=float, default=0.3, help="share of the training episodes fitted on")
    parser.add_argument("--variants", default=",".join(VARIANTS))
    args = parser.parse_args()
    torch.set_num_threads(1)
    data = load(args.run)
    spans = recurrent_student.episode_spans(data.starts)
    rng = np.random.default_rng(0)
    order = rng.permutation(len(spans))
    held = np.sort(order[: len(spans) // 10])
    train = np.sort(order[len(spans) // 10 :][: int(args.share * (len(spans) - len(spans) // 10))])
    train_data, held_data = select(data, spans, train), select(data, spans, held)
    del data
    print(f"{len(train)} episodes ({len(train_data[1])} decisions) fitted, {len(held)} ({len(held_data[1])}) held out")
    from aaai.config import env_part, load_config
    from aaai.env import AnimalAIEnv
    from aaai.train.camera_student import seen_space

    config = load_config(args.run / "config.yaml")
    env = AnimalAIEnv(config=env_part(config, 0.0))
    spaces = seen_space(env.observation_space), env.action_space
    env.close()
    done = set()
    if args.out.exists():
        with open(args.out) as handle:
            done = {row["variant"] for row in csv.DictReader(handle)}
    for name in args.variants.split(","):
        if name in done:
            continue
        kind, epochs, sequence, batch, rate, final = VARIANTS[name]
        torch.manual_seed(0)
        started = time.process_time()
        if kind in ("lstm", "shuffled"):
            policy = recurrent_student.build_policy(*spaces, config.train.net_width)
            fitter = recurrent_student.fit_sequences if kind == "lstm" else recurrent_student.fit_shuffled_chunks
            fit_loss = fitter(policy, *train_data, epochs, 0, sequence, rate, batch, final_learning_rate=final)
            minutes = (time.process_time() - started) / 60
            train_loss, held_loss = sequence_loss(policy, *train_data), sequence_loss(policy, *held_data)
        else:
            policy = student.build_policy(*spaces, config.train.net_width)
            fit_loss = student.fit(policy, train_data[0], train_data[1], epochs, 0)
            minutes = (time.process_time() - started) / 60
            train_loss, held_loss = flat_loss(policy, *train_data[:2]), flat_loss(policy, *held_data[:2])
        row = {
            "variant": name,
            "student": kind,
            "epochs": epochs,
            "sequence": sequence,
            "batch": batch,
            "learning_rate": rate,
            "final_learning_rate": final or "",
            "fit_loss": round(fit_loss, 5),
            "train_loss": round(train_loss, 5),
            "held_out_loss": round(held_loss, 5),
            "cpu_minutes": round(minutes, 2),
        }
        print(row, flush=True)
        new = not args.out.exists()
        with open(args.out, "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(row))
            if new:
                writer.writeheader()
            writer.writerow(row)


if __name__ == "__main__":
    main()
