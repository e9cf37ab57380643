"""`aaai train --teacher reference`: a student that sees only the agent's senses, taught by DAgger.

DAgger (Ross, Gordon and Bagnell, 2011): the student acts, and the teacher labels every state the
student visits with the action it would take there. Here the teacher is the reference controller
(aaai.task.reference), which reads the level spec and the live positions of every object; the student
gets only the ordinary observation (rays, proprioception, the camera if on). Each iteration

1. plays ``dagger_episodes`` episodes spread evenly over the curriculum's cells, on training seeds,
   each for at most ``dagger_episode_cap`` decisions; at every agent decision the teacher's action
   is recorded as the label, and the action taken is the teacher's with probability
   beta ** iteration, else the student's (iteration 0: the teacher alone, which is behaviour
   cloning);
2. adds the (observation, label) pairs to everything gathered so far;
3. refits the student to all of it by supervised learning: the mean action of a
   stable-baselines3 ``MultiInputPolicy`` regressed on the labels (mean squared error, Adam), or,
   with ``agent.action_mode: discrete``, its choices classified (cross-entropy: the teacher's gait
   commands labelled with the nearest choice, aaai.sim.gait.choice_of_command), continuing from
   the last round's weights.

The teacher is stateful: it notices when it makes no progress and backs off, and it times its
plank pushes. While the student drives, those clocks are held (``ReferenceController.
student_drove``): a first version let them run, and labelled the student's detours "stuck, back
off", and its students got worse with every round after the third (docs: Learned agents).

The student is an ordinary stable-baselines3 PPO model in an ordinary run folder, so ``aaai eval
--policy RUN`` scores it and ``aaai train --init-from RUN`` fine-tunes it with PPO. Every
iteration is a checkpoint (its model, and its data in ``dagger/``), so ``--resume`` continues a run
after the last finished iteration; ``train.dagger_data_from`` (``aaai train --data-from RUN``)
starts a run from another run's saved rounds, refitted before any round is played. Episodes run
in worker processes (``train.processes``, by default ``train.num_envs`` up to the usable cores);
with the same config a run repeats exactly.

The student's inputs are only the observation. By default (``train.student_policy: mlp``) its
network has no state; what it remembers is what the senses keep (``sensors.ray_memory``: the rays'
sightings of food 1, 2, 4 ... 64 decisions back in configs/student.yaml). With
``train.student_policy: lstm`` it is sb3-contrib's RecurrentPPO policy, which carries a memory
through the episode, trained on whole episodes (aaai.train.recurrent_student). What a level needs
beyond that is measured by ``aaai diagnose`` (docs, Learned agents).
"""

from __future__ import annotations

import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Callable

import numpy as np

from aaai.config import TEACHERS, Config, ConfigError, env_part, load_config
from aaai.levels.seeds import TRAIN_SEEDS
from aaai.scoring.model_config import save_model
from aaai.scoring.runs import RunFolder, check_writable
from aaai.train import recurrent_student
from aaai.train.camera_student import (
    Dataset,
    as_stored,
    check_memory,
    decision_bytes,
    keep_round,
    round_share,
    seen_space,
)
from aaai.train.vector import Episode, worker_processes

BATCH_SIZE = 1024
LEARNING_RATE = 1e-3
EPISODES_PER_JOB = 4  # episodes a worker plays per task: small enough to share the load evenly
DATA_FOLDER = "dagger"


@dataclass(frozen=True)
class DaggerSettings:
    """What a DAgger run does (the run's config, ``train`` section)."""

    iterations: int  # train.dagger_iterations
    episodes: int  # train.dagger_episodes: per iteration, spread evenly over the cells
    beta: float  # train.dagger_beta: the teacher acts with probability beta ** iteration
    epochs: int  # train.dagger_epochs: passes over the aggregated data per refit
    episode_cap: int  # train.dagger_episode_cap: decisions an episode is played for at most
    net_width: int  # train.net_width: two hidden layers of this width, as PPO's
    log_std_init: float  # train.log_std_init: the exploration a PPO fine-tune starts from
    workers: int  # train.processes (aaai.train.vector.worker_processes): worker processes playing episodes
    seed: int  # train.seed
    student_policy: str = "mlp"  # train.student_policy: mlp, or lstm (aaai.train.recurrent_student)
    sequence: int = 64  # train.dagger_sequence: an lstm student's chunks of backpropagation through time
    chunks: str = "shuffled"  # train.dagger_chunks: an lstm student's steps: shuffled chunks, or episodes
    learning_rate_end: float = LEARNING_RATE  # train.dagger_learning_rate_end: a refit's last step size

    @classmethod
    def from_config(cls, config: Config) -> "DaggerSettings":
        train = config.train
        return cls(
            train.dagger_iterations,
            train.dagger_episodes,
            train.dagger_beta,
            train.dagger_epochs,
            train.dagger_episode_cap,
            train.net_width,
            train.log_std_init,
            worker_processes(train),
            train.seed,
            train.student_policy,
            train.dagger_sequence,
            train.dagger_chunks,
            train.dagger_learning_rate_end,
        )


# --- the student's network --------------------------------------------------------------
def build_policy(observation_space, action_space, net_width: int, log_std_init: float = 0.0):
    """The student: stable-baselines3's MultiInputPolicy as PPO builds it."""
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy

    return MultiInputActorCriticPolicy(
        observation_space,
        action_space,
        lambda _: LEARNING_RATE,
        net_arch=[net_width, net_width],
        log_std_init=log_std_init,
    )


def build_student(kind: str, observation_space, action_space, net_width: int):
    """The student's network of ``kind`` (train.student_policy): mlp or lstm."""
    if kind == "lstm":
        return recurrent_student.build_policy(observation_space, action_space, net_width, learning_rate=LEARNING_RATE)
    return build_policy(observation_space, action_space, net_width)


def act(policy, observation: dict) -> np.ndarray:
    """The student's deterministic action for one observation (clipped to the action space)."""
    action, _ = policy.predict(observation, deterministic=True)
    return action


def mean_actions(policy, observations: dict):
    """The policy's mean action for a batch of observations (torch tensors), with gradients; for a
    discrete action space (``agent.action_mode: discrete``) the logits of every part's choices."""
    features = policy.extract_features(observations, policy.pi_features_extractor)
    latent = policy.mlp_extractor.forward_actor(features)
    return policy.action_net(latent)


def imitation_loss(policy, outputs, targets):
    """How far ``outputs`` (:func:`mean_actions`) are from the teacher's labels ``targets``: the mean
    squared error of continuous actions; for discrete ones, the sum over the action's parts of the
    cross-entropy of that part's choices, so the student learns which choice the teacher makes, not
    the mean of choices it cannot tell apart."""
    import torch
    from gymnasium import spaces

    space = policy.action_space
    if isinstance(space, spaces.MultiDiscrete):
        parts = torch.split(outputs, [int(n) for n in space.nvec], dim=1)
        return sum(
            torch.nn.functional.cross_entropy(logits, target) for logits, target in zip(parts, targets.long().unbind(1))
        )
    return torch.nn.functional.mse_loss(outputs, targets)


# --- playing episodes -------------------------------------------------------------------
@dataclass(frozen=True)
class Job:
    config: Config
    weights: dict | None  # the student's state dict; None: the teacher acts alone
    net_width: int
    beta: float  # the probability that the teacher's action is taken
    iteration: int
    episodes: tuple[tuple[int, int, int], ...]  # (level, difficulty, seed)
    cap: int = 0  # decisions an episode is played for at most; 0: to its own end (the time limit)
    student_policy: str = "mlp"  # train.student_policy: mlp, or lstm (its hidden state carried through an episode)


def play_job(job: Job) -> dict:
    """In a worker: plays the job's episodes; returns their observations, the teacher's labels,
    where each episode starts and one Episode record each. A recurrent student sees every
    observation (its hidden state carried through the episode), the teacher's decisions too."""
    import torch

    from aaai.env import AnimalAIEnv
    from aaai.task.search import teacher as controller

    torch.set_num_threads(1)
    env = AnimalAIEnv(config=env_part(job.config, 0.0))
    teacher = controller(job.config.train.teacher, env)
    student, actor = None, None
    if job.weights is not None:
        student = build_student(job.student_policy, seen_space(env.observation_space), env.action_space, job.net_width)
        student.load_state_dict(job.weights)
        student.set_training_mode(False)
        if job.student_policy == "lstm":
            actor = recurrent_student.RecurrentActor(student)
    observations: dict[str, list] = {key: [] for key in env.observation_space.spaces}
    labels, starts, records, taught, capped = [], [], [], 0, []
    try:
        for level, difficulty, seed in job.episodes:
            observation, info = env.reset(seed=seed, options={"level": level, "difficulty": difficulty})
            teacher.reset(seed)
            rng = np.random.default_rng([seed, job.iteration])
            total, task, length = 0.0, 0.0, 0
            if actor is not None:
                actor.reset()
            while True:
                label = np.asarray(teacher(observation), np.float32)
                for key, value in observation.items():
                    observations[key].append(value)
                labels.append(label)
                starts.append(length == 0)
                own = actor(observation) if actor is not None else None  # the memory sees every decision
                if student is None or rng.random() < job.beta:
                    action, taught = label, taught + 1
                else:
                    action = own if own is not None else act(student, observation)
                    teacher.student_drove(env.hold * env.control_dt)
                observation, reward, terminated, truncated, info = env.step(action)
                total += reward
                task += reward - info["reward_terms"].get("shaping", 0.0)
                length += 1
                if terminated or truncated:
                    break
                if job.cap and length >= job.cap:  # stopped short of the episode's end: counted
                    capped.append(level)
                    break
            records.append(
                Episode(
                    0,
                    level,
                    difficulty,
                    seed,
                    total,
                    task,
                    length,
                    info["food_eaten"],
                    info["wall_hits"],
                    bool(info["fell"]),
                    bool(info["blew_up"]),
                    info["max_reward"],
                )
            )
    finally:
        env.close()
    return {
        "observations": as_stored(observations, env.observation_space),  # images uint8, channel-first
        "labels": np.stack(labels),
        "starts": np.asarray(starts, bool),
        "episodes": records,
        "taught": taught,
        "capped": capped,  # the level of each episode stopped at the cap before its end
    }


def plan_episodes(cells: list[tuple[int, int]], count: int, rng: np.random.Generator) -> list[tuple[int, int, int]]:
    """``count`` episodes spread evenly over ``cells`` (each cell once before any twice, in a
    shuffled order), each on a fresh training seed."""
    order: list[tuple[int, int]] = []
    while len(order) < count:
        order.extend(cells[i] for i in rng.permutation(len(cells)))
    seeds = rng.integers(TRAIN_SEEDS.start, TRAIN_SEEDS.stop, size=count)
    return [(level, difficulty, int(seed)) for (level, difficulty), seed in zip(order[:count], seeds)]


# --- fitting ----------------------------------------------------------------------------
def fit(
    policy, observations: dict, labels: np.ndarray, epochs: int, seed: int, final_learning_rate: float | None = None
) -> float:
    """Regresses the policy's mean action on the labels; returns the last epoch's mean loss. With
    ``final_learning_rate`` the step size falls to it from LEARNING_RATE along a cosine over the fit."""
    import torch

    generator = torch.Generator().manual_seed(seed)
    inputs = {  # images stay uint8 (a quarter of float32's size); the policy reads each batch as floats
        key: torch.as_tensor(value) if value.dtype == np.uint8 else torch.as_tensor(value, dtype=torch.float32)
        for key, value in observations.items()
    }
    targets = torch.as_tensor(labels, dtype=torch.float32)
    optimizer = torch.optim.Adam(policy.parameters(), lr=LEARNING_RATE)
    policy.set_training_mode(True)
    size, loss_sum, batches = len(targets), 0.0, 0
    step_size = recurrent_student.cosine_schedule(LEARNING_RATE, final_learning_rate, epochs * -(-size // BATCH_SIZE))
    step = 0
    for _ in range(epochs):
        order = torch.randperm(size, generator=generator)
        loss_sum, batches = 0.0, 0
        for start in range(0, size, BATCH_SIZE):
            index = order[start : start + BATCH_SIZE]
            batch = {key: value[index] for key, value in inputs.items()}
            loss = imitation_loss(policy, mean_actions(policy, batch), targets[index])
            optimizer.zero_grad()
            loss.backward()
            for group in optimizer.param_groups:
                group["lr"] = step_size(step)
            optimizer.step()
            step += 1
            loss_sum, batches = loss_sum + loss.item(), batches + 1
    policy.set_training_mode(False)
    return loss_sum / max(batches, 1)


# --- the run ----------------------------------------------------------------------------
@dataclass
class StudentResult:
    run: RunFolder
    steps: int  # agent decisions gathered (labelled observations)
    episodes: int
    resumed_from: int


def check_teachable(config: Config) -> None:
    if config.train.teacher not in TEACHERS:
        raise ConfigError(
            f"config key 'train.teacher': got {config.train.teacher!r}; allowed for a student run: "
            + ", ".join(TEACHERS)
        )
    if config.agent.action_mode == "velocity":
        raise ConfigError(
            "config key 'agent.action_mode': got 'velocity'; allowed for a student of the reference: "
            "gait, discrete or rotation (the reference steers the gait by joint angles)"
        )
    check_memory(config)  # a student with images: its labelled data within a stated bound
    if config.train.student_policy == "lstm":
        recurrent_student.check_available()
        if config.train.dagger_max_decisions:
            raise ConfigError(
                f"config key 'train.dagger_max_decisions': got {config.train.dagger_max_decisions}; allowed with "
                "train.student_policy lstm: 0 (a sample of decisions breaks the episodes a recurrent student "
                "learns from)"
            )


def import_rounds(source: Path, folder: Path, config: Config) -> int:
    """Puts the saved rounds of the DAgger run ``source`` (``train.dagger_data_from``; see
    :func:`source_rounds`) into this run's data ``folder`` (hard links where the file system allows,
    else copies; a round file is never changed once written); returns how many."""
    import shutil

    rounds = source_rounds(source, config)
    folder.mkdir(parents=True, exist_ok=True)
    for path in rounds:
        target = folder / path.name
        partial = target.with_name(target.name + ".partial.npz")
        partial.unlink(missing_ok=True)
        try:
            partial.hardlink_to(path)
        except OSError:
            shutil.copyfile(path, partial)
        partial.replace(target)
    return len(rounds)


def source_rounds(source: Path, config: Config) -> list[Path]:
    """The saved rounds of the DAgger run ``source`` that a run of ``config`` starts from: the first
    ``train.dagger_iterations`` of them at most. The source must be a run of the same teacher, body
    and senses, whose rounds hold what this student learns from (an lstm student: the episodes'
    starts); else one ConfigError says what differs."""
    key = "config key 'train.dagger_data_from'"
    config_file = source / "config.yaml"
    if not config_file.is_file():
        raise ConfigError(f"{key}: got {str(source)!r}, which has no config.yaml; allowed: a run folder of aaai train")
    theirs = load_config(config_file)
    for name, ours_part, their_part in (
        ("train.teacher", config.train.teacher, theirs.train.teacher),
        ("agent", config.agent, theirs.agent),
        ("sensors", config.sensors, theirs.sensors),
    ):
        if ours_part != their_part:
            raise ConfigError(
                f"{key}: got {str(source)!r}, whose {name} differs from this run's; allowed: a DAgger run of "
                "the same teacher, body and senses (its labels are that teacher's actions on those observations)"
            )
    rounds: list[Path] = []
    while len(rounds) < config.train.dagger_iterations:
        path = source / DATA_FOLDER / f"iteration_{len(rounds):03d}.npz"
        if not path.is_file():
            break
        rounds.append(path)
    if not rounds:
        raise ConfigError(
            f"{key}: got {str(source)!r}, which has no saved rounds ({DATA_FOLDER}/iteration_000.npz); "
            "allowed: a run of aaai train with a teacher"
        )
    if config.train.student_policy == "lstm":
        for path in rounds:
            with np.load(path) as data:
                if "episode_starts" not in data.files:
                    raise ConfigError(
                        f"{key}: {str(path)!r} does not record where its episodes start; allowed with "
                        "train.student_policy lstm: rounds saved with their episodes' starts"
                    )
    return rounds


def _save_data(folder: Path, iteration: int, observations: dict, labels: np.ndarray, starts: np.ndarray) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    final = folder / f"iteration_{iteration:03d}.npz"
    partial = final.with_name(final.name + ".partial.npz")
    np.savez(
        partial, labels=labels, episode_starts=starts, **{f"obs_{key}": value for key, value in observations.items()}
    )
    partial.replace(final)


def train_student(
    run_dir: str | Path,
    config: Config | None = None,
    resume: bool = False,
    say: Callable[[str], None] = print,
    rounds: int | None = None,
) -> StudentResult:
    """Starts a DAgger run in ``run_dir`` with ``config`` (resolved), or resumes the one there;
    the run folder is locked for the whole call, as in aaai.train.training.train."""
    run = RunFolder(run_dir)
    check_writable(run.path, "--resume" if resume else "--run", folder=True)
    with run.locked("--resume" if resume else "--run"):
        return _train_student(run, config, resume, say, rounds)


def _train_student(
    run: RunFolder, config: Config | None, resume: bool, say: Callable[[str], None], rounds: int | None
) -> StudentResult:
    import torch

    from aaai.env import AnimalAIEnv
    from aaai.train.training import with_proprioception

    done, state = 0, None
    if resume:
        config = load_config(run.read_config())
        point = run.resume_point(needs_model=True, say=say)
        if point is not None:
            state = point[1]
            done = state["agent"]["iterations_done"]
        if rounds is not None:
            config = move_last_round(run, config, done, rounds)
        run.trim_episodes(state["step"] if state else 0)  # to its header when there is no checkpoint
    else:
        if config is None:
            raise ConfigError(
                "train_student: a new run needs a config (aaai.config.load_config); a resumed one reads its own"
            )
        config = with_proprioception(config)
        check_teachable(config)
        if config.train.dagger_data_from:
            source_rounds(Path(config.train.dagger_data_from), config)  # refused before the run folder is made
        run.create(config)
    check_teachable(config)
    settings = DaggerSettings.from_config(config)
    torch.manual_seed(settings.seed)
    torch.set_num_threads(1)
    env = AnimalAIEnv(config=env_part(config, 0.0))
    model = recurrent_student.new_model(env, config) if settings.student_policy == "lstm" else _ppo(env, config)
    env.close()
    data_folder = run.path / DATA_FOLDER
    data = Dataset(config.train.dagger_max_decisions or None)  # aaai.train.camera_student: images as uint8
    if data.capacity:
        say(data.bound(decision_bytes(model.observation_space, model.action_space.shape or ())))
    if done:
        data.load(data_folder, done)
        latest = run.latest_checkpoint()
        assert latest is not None, "a resumed student's iterations were read from its checkpoint"
        model.policy.load_state_dict(torch.load(latest / "student.pth", weights_only=True))

    def refit(iteration: int) -> float:
        end = None if settings.learning_rate_end == LEARNING_RATE else settings.learning_rate_end
        if settings.student_policy == "lstm":
            fitter = (
                recurrent_student.fit_shuffled_chunks
                if settings.chunks == "shuffled"
                else recurrent_student.fit_sequences
            )
            return fitter(
                model.policy,
                data.observations,
                data.labels,
                data.starts,
                settings.epochs,
                settings.seed + iteration,
                settings.sequence,
                LEARNING_RATE,
                BATCH_SIZE,
                final_learning_rate=end,
            )
        return fit(model.policy, data.observations, data.labels, settings.epochs, settings.seed + iteration, end)

    def checkpoint(step: int, iterations_done: int) -> None:
        if hasattr(model.policy, "log_std"):  # a discrete student's choices have no spread to set
            with torch.no_grad():
                model.policy.log_std.fill_(settings.log_std_init)

        def save(path: Path) -> None:
            save_model(model, path, config)  # the model file carries the run's config
            torch.save(model.policy.state_dict(), path.with_name("student.pth"))

        # No sampler state: the plan of each iteration is a pure function of (seed, iteration).
        run.save_checkpoint(
            step,
            {"curriculum": None, "agent": {"iterations_done": iterations_done}},
            save,
            final=iterations_done == settings.iterations,
        )

    if not done and config.train.dagger_data_from:  # another run's rounds: refit on them, then go on
        started = time.perf_counter()
        done = import_rounds(Path(config.train.dagger_data_from), data_folder, config)
        data.load(data_folder, done)
        loss = refit(done - 1)
        line = {
            "iteration": done - 1,
            "beta": round(settings.beta ** (done - 1), 6),
            "episodes": 0,
            "decisions": 0,
            "teacher_share": 0.0,
            "passed": 0,
            "pass_rate": 0.0,
            "dataset": data.size,
            "loss": round(loss, 6),
            "seconds": round(time.perf_counter() - started, 1),
        }
        _log_iteration(run.path / "dagger.csv", line)
        run.log_episodes(data.size, [])  # none played: the log is its header
        say(
            f"DAgger: {done} rounds of {config.train.dagger_data_from} ({data.size} labelled decisions) refitted, "
            f"loss {loss:.4f}, {line['seconds']:.0f} s"
        )
        checkpoint(data.size, done)
    cells = [(level, d) for level in config.curriculum.levels for d in config.curriculum.difficulties]
    episodes_logged = 0
    context = get_context("spawn")  # workers start clean: no copy of this process's torch or PyBullet state
    with ProcessPoolExecutor(max_workers=settings.workers, mp_context=context) as pool:
        for iteration in range(done, settings.iterations):
            started = time.perf_counter()
            rng = np.random.default_rng([settings.seed, iteration])
            plan = plan_episodes(cells, settings.episodes, rng)
            beta = settings.beta**iteration
            weights = None if iteration == 0 else {k: v.clone() for k, v in model.policy.state_dict().items()}
            jobs = [
                Job(
                    config,
                    weights,
                    settings.net_width,
                    beta,
                    iteration,
                    tuple(plan[i : i + EPISODES_PER_JOB]),
                    settings.episode_cap,
                    settings.student_policy,
                )
                for i in range(0, len(plan), EPISODES_PER_JOB)
            ]
            results = list(pool.map(play_job, jobs))
            gathered = sum(len(r["labels"]) for r in results)
            new_obs, new_labels, new_starts = keep_round(
                results, round_share(config), np.random.default_rng([settings.seed, iteration, 1])
            )
            finished = [episode for r in results for episode in r["episodes"]]
            taught = sum(r["taught"] for r in results)
            capped = [level for r in results for level in r["capped"]]
            del results  # the round's whole data: only its kept sample stays in memory
            _save_data(data_folder, iteration, new_obs, new_labels, new_starts)
            data.add(new_obs, new_labels, new_starts)
            loss = refit(iteration)
            step = data.size
            run.log_episodes(step, finished)
            episodes_logged += len(finished)
            passed = sum(e.max_reward > 0 and e.task_return / e.max_reward >= 0.8 for e in finished)
            line = {
                "iteration": iteration,
                "beta": round(beta, 6),
                "episodes": len(finished),
                "decisions": gathered,
                "teacher_share": round(taught / max(gathered, 1), 4),
                "passed": passed,
                "pass_rate": round(passed / max(len(finished), 1), 4),
                "dataset": step,
                "loss": round(loss, 6),
                "seconds": round(time.perf_counter() - started, 1),
            }
            _log_iteration(run.path / "dagger.csv", line)
            say(
                f"DAgger iteration {iteration}: beta {beta:.3f}, {len(finished)} episodes passed {passed} "
                f"({100 * line['pass_rate']:.0f} %, teacher's share of actions {100 * line['teacher_share']:.0f} %), "
                f"{step} labelled decisions, loss {loss:.4f}, {line['seconds']:.0f} s"
                + capped_note(capped, settings.episode_cap)
            )
            checkpoint(step, iteration + 1)
    return StudentResult(run, data.size, episodes_logged, done)


def capped_note(levels: list[int], cap: int) -> str:
    """The round's episodes stopped at ``train.dagger_episode_cap`` before their end, by level: the
    teacher's labels never show how those end (an empty string when none was)."""
    if not levels:
        return ""
    from aaai.levels import get_level

    counts = Counter(levels)
    by_level = ", ".join(f"{get_level(level).label} {counts[level]}" for level in sorted(counts))
    return (
        f"; {len(levels)} episode{'s' if len(levels) > 1 else ''} stopped at the cap of {cap} decisions before "
        f"their end ({by_level}; "
        "train.dagger_episode_cap 0 plays each to its time limit)"
    )


def move_last_round(run: RunFolder, config: Config, done: int, rounds: int) -> Config:
    """On resume: the run's config with its end moved to ``rounds`` rounds of DAgger (recorded in the
    run folder); refused at or below the rounds the run has done. The rounds before are unchanged:
    each round's plan and mixing share depend on the seed and the round's number only."""
    if rounds <= done:
        raise ConfigError(
            f"--rounds: got {rounds}; the run {str(run.path)!r} already has {done} rounds of DAgger; "
            f"allowed: more than {done}"
        )
    if config.train.dagger_max_decisions:
        raise ConfigError(
            f"--rounds: got {rounds} for a run with train.dagger_max_decisions "
            f"{config.train.dagger_max_decisions}, whose rounds each keep that cap over its "
            f"{config.train.dagger_iterations} rounds; allowed: no --rounds (a new run with train.dagger_iterations)"
        )
    config = load_config(config, dagger_iterations=rounds)
    run.update_config(config)
    return config


def _ppo(env, config: Config):
    """A PPO model holding the stateless student (what the run saves, and PPO fine-tunes)."""
    from stable_baselines3 import PPO

    train = config.train
    return PPO(
        "MultiInputPolicy",
        env,
        policy_kwargs={"net_arch": [train.net_width] * 2, "log_std_init": train.log_std_init},
        learning_rate=train.learning_rate,
        n_steps=train.n_steps,
        batch_size=train.batch_size,
        seed=train.seed,
        device="cpu",
        verbose=0,
    )


def _log_iteration(path: Path, line: dict) -> None:
    import csv

    new = not path.exists()
    with open(path, "a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(line))
        if new:
            writer.writeheader()
        writer.writerow(line)
        handle.flush()
