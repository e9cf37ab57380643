"""A student that sees: the images of a DAgger student (aaai.train.student) as its network reads them, and
the memory its labelled data may take.

The camera gives uint8 H x W x C images (``sensors.camera``). stable-baselines3 hands images to a policy
channel-first: PPO wraps its environment in ``VecTransposeImage``, and ``predict`` transposes one
observation itself. So the student's network is built for the space as the model sees it
(:func:`seen_space`), and its labelled images are kept channel-first and as uint8 (:func:`as_stored`),
a quarter of their size in float32; the refit turns each batch into floats (stable-baselines3 divides
images by 255 as it reads them).

The network is ``MultiInputPolicy``'s own: its ``CombinedExtractor`` gives each image stable-baselines3's
NatureCNN (three convolutions, 8x8 stride 4, 4x4 stride 2, 3x3; a linear layer to 256 features) and
flattens the other keys beside it. At 64 px that is about 3.4 million multiply-adds a forward pass, less
than a millisecond on one core (bench/camera_student.py measures it against the camera's rendering,
which costs more): a smaller network would save little, and this one is among the classes a model file
may name (aaai.scoring.model_io), so a camera student loads and scores without ``--trust-model``.
NatureCNN needs images of 36 px or more.

Memory: one decision's images at 64 px RGB are 12,288 bytes, so 300,000 labelled decisions would take
3.7 GB. ``train.dagger_max_decisions`` caps the data: each round keeps a seeded uniform sample of at most
``dagger_max_decisions // dagger_iterations`` of its decisions (:func:`keep_round`), and the data of
all rounds lives in one buffer of exactly that many rows, allocated once (:class:`Dataset`). A student
with images and no cap is refused when its data could grow past :data:`MEMORY_LIMIT`
(:func:`check_memory`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aaai.config import Config, ConfigError, env_part
from aaai.scoring.model_spaces import as_model_sees

MEMORY_LIMIT = 4 * 2**30  # bytes the labelled data of a student with images may reach without a cap
LABEL_DTYPE = np.float32


def seen_space(observation_space):
    """The observation space as the student's network sees it: images channel-first."""
    return as_model_sees(observation_space)


def as_stored(observations: dict[str, list], observation_space) -> dict[str, np.ndarray]:
    """One worker's observations (a list per key) as arrays the refit reads: each image key N x C x H x W
    uint8, the others stacked as they are."""
    seen = seen_space(observation_space)
    stored = {}
    for key, values in observations.items():
        array = np.stack(values)
        if seen[key].shape != observation_space[key].shape:  # an image: H x W x C -> C x H x W
            array = np.ascontiguousarray(array.transpose(0, 3, 1, 2))
        stored[key] = array
    return stored


def decision_bytes(observation_space, action_shape: tuple[int, ...]) -> int:
    """Bytes one labelled decision takes in the data: its observation as stored, and its label."""
    total = int(np.prod(action_shape)) * np.dtype(LABEL_DTYPE).itemsize
    for space in observation_space.spaces.values():
        total += int(np.prod(space.shape)) * np.dtype(space.dtype).itemsize
    return total


def has_images(config: Config) -> bool:
    return config.sensors.camera


def check_memory(config: Config) -> tuple[int | None, int]:
    """The labelled data's bound: (decisions kept at most or None for all, bytes a decision). Refuses a
    cap below one decision a round, and a student with images and no cap whose data could pass
    :data:`MEMORY_LIMIT` (every round's every episode played for as long as it can last: :func:`longest_episode`)."""
    from aaai.env import AnimalAIEnv

    train = config.train
    env = AnimalAIEnv(config=env_part(config, 0.0))
    try:
        shape = env.action_space.shape
        assert shape is not None, "a Box action space has a shape"
        size = decision_bytes(env.observation_space, shape)
        longest = longest_episode(config, env.hold)
    finally:
        env.close()
    cap = train.dagger_max_decisions
    if cap and cap < train.dagger_iterations:
        raise ConfigError(
            f"config key 'train.dagger_max_decisions': got {cap}; allowed: 0 (no cap) or at least "
            f"train.dagger_iterations ({train.dagger_iterations}): each round keeps cap / iterations decisions"
        )
    if cap:
        return cap, size
    worst = train.dagger_iterations * train.dagger_episodes * longest
    if has_images(config) and worst * size > MEMORY_LIMIT:
        raise ConfigError(
            f"config key 'train.dagger_max_decisions': got 0 (no cap) for a student with the camera, whose "
            f"labelled data could reach {_gib(worst * size)} ({worst:,} decisions of {size:,} bytes: "
            f"dagger_iterations x dagger_episodes x the decisions of an episode at most); allowed: a cap of at most "
            f"{MEMORY_LIMIT // size:,} decisions ({_gib(MEMORY_LIMIT)}), or a smaller sensors.camera_resolution"
        )
    return None, size


def longest_episode(config: Config, hold: int) -> int:
    """Decisions a DAgger episode is played for at most: ``train.dagger_episode_cap``, or with 0 the
    longest an episode can last (``episode.max_steps``, or a level's longest time limit), in
    decisions of ``hold`` control steps."""
    from aaai.levels import LONGEST_TIME_LIMIT

    if config.train.dagger_episode_cap:
        return config.train.dagger_episode_cap
    steps = config.episode.max_steps
    if steps == "auto":
        steps = round(LONGEST_TIME_LIMIT / config.physics.control_dt)
    return -(-int(steps) // hold)


def _gib(size: float) -> str:
    return f"{size / 2**30:.2f} GiB"


def round_share(config: Config) -> int | None:
    """Decisions a round keeps at most (None: all of them)."""
    cap = config.train.dagger_max_decisions
    return cap // config.train.dagger_iterations if cap else None


def keep_round(results: list[dict], keep: int | None, rng: np.random.Generator) -> tuple[dict, np.ndarray, np.ndarray]:
    """One round's observations, labels and episode starts from its workers' results: all of them, or
    a uniform sample of ``keep`` (drawn from ``rng``, in the order played) when there are more (each
    kept decision then starts a sequence of its own: a sample is for a stateless student only). Each
    result's part is taken from it directly: the round's data is never concatenated whole first."""
    counts = [len(result["labels"]) for result in results]
    total = sum(counts)
    chosen: list[np.ndarray | slice]
    if keep is None or total <= keep:
        chosen = [slice(None)] * len(results)
    else:
        picked = np.sort(rng.choice(total, keep, replace=False))
        edges = np.concatenate([[0], np.cumsum(counts)])
        chosen = [picked[(picked >= a) & (picked < b)] - a for a, b in zip(edges[:-1], edges[1:])]
    keys = results[0]["observations"]
    observations = {
        key: np.concatenate([result["observations"][key][part] for result, part in zip(results, chosen)])
        for key in keys
    }
    labels = np.concatenate([result["labels"][part] for result, part in zip(results, chosen)])
    if keep is None or total <= keep:
        starts = np.concatenate([result["starts"] for result in results])
    else:
        starts = np.ones(len(labels), bool)
    return observations, labels, starts


class Dataset:
    """DAgger's labelled decisions of all rounds so far. With a ``capacity`` (``train.dagger_max_decisions``)
    one buffer of that many rows per key is allocated at the first round and filled round by round, so
    the data never takes more than ``capacity`` x :func:`decision_bytes`, nor is copied to grow; without
    one, each round's data is appended (a copy each round)."""

    def __init__(self, capacity: int | None = None):
        self.capacity = capacity
        self.size = 0
        self._observations: dict[str, np.ndarray] = {}
        self._labels: np.ndarray | None = None
        self._starts = np.zeros(self.capacity or 0, bool)

    def add(self, observations: dict[str, np.ndarray], labels: np.ndarray, starts: np.ndarray | None = None) -> None:
        """Appends a round's decisions; ``starts`` marks where each episode begins (None: the round is
        one sequence, as data saved before starts were recorded)."""
        count = len(labels)
        if starts is None:
            starts = np.arange(count) == 0
        if self._labels is None:
            rows = self.capacity if self.capacity is not None else 0
            self._observations = {k: np.empty((rows, *v.shape[1:]), v.dtype) for k, v in observations.items()}
            self._labels = np.empty((rows, *labels.shape[1:]), LABEL_DTYPE)
        if self.capacity is None:
            self._observations = {
                k: np.concatenate([v[: self.size], observations[k]]) for k, v in self._observations.items()
            }
            self._labels = np.concatenate([self._labels[: self.size], labels.astype(LABEL_DTYPE)])
            self._starts = np.concatenate([self._starts[: self.size], np.asarray(starts, bool)])
        else:
            if self.size + count > self.capacity:
                raise ValueError(f"the data holds {self.capacity} decisions; {self.size} + {count} do not fit")
            for key, array in self._observations.items():
                array[self.size : self.size + count] = observations[key]
            self._labels[self.size : self.size + count] = labels
            self._starts[self.size : self.size + count] = starts
        self.size += count

    def bound(self, size: int) -> str:
        """The data's bound in words, for decisions of ``size`` bytes."""
        return (
            f"labelled data: at most {self.capacity:,} decisions of {size:,} bytes, {_gib((self.capacity or 0) * size)}"
        )

    @property
    def observations(self) -> dict[str, np.ndarray]:
        return {key: array[: self.size] for key, array in self._observations.items()}

    @property
    def labels(self) -> np.ndarray:
        return np.zeros((0,), LABEL_DTYPE) if self._labels is None else self._labels[: self.size]

    @property
    def starts(self) -> np.ndarray:
        """Where each episode of the data begins (a recurrent student's sequences)."""
        return self._starts[: self.size]

    @property
    def nbytes(self) -> int:
        """Bytes the data's arrays hold (the whole buffer, with a capacity)."""
        arrays = list(self._observations.values()) + ([self._labels] if self._labels is not None else [])
        return sum(array.nbytes for array in arrays)

    def load(self, folder: Path, iterations: int) -> None:
        """Fills the data from a run's saved rounds (``iteration_NNN.npz``), one round at a time."""
        for iteration in range(iterations):
            path = folder / f"iteration_{iteration:03d}.npz"
            if not path.is_file():
                raise ConfigError(f"--resume: {str(path)!r} is missing; the run's data cannot be rebuilt")
            with np.load(path) as data:
                observations = {name[4:]: data[name] for name in data.files if name.startswith("obs_")}
                starts = data["episode_starts"] if "episode_starts" in data.files else None
                self.add(observations, data["labels"], starts)
