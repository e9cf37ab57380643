"""`aaai train`'s decisions: which trainer runs (PPO on stable-baselines3 or RLlib, a DAgger student), its rules.

The command line parses the flags into a config; :func:`check_options` refuses the flags that cannot
go together, and :func:`train_run` picks the trainer, checks its rules and runs it with its progress.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

from aaai.config import Config, ConfigError, load_config
from aaai.jobs import Display, quietly
from aaai.scoring.runs import RunFolder, run_backend
from aaai.train.rllib_learner import train_rllib
from aaai.train.student import StudentResult
from aaai.train.training import Progress, TrainResult, train


@dataclass
class Trained:
    """What :func:`train_run` did: the trainer's result, and whether it trained a student of a teacher
    (its steps are labelled agent decisions and its resume point DAgger iterations)."""

    result: TrainResult | StudentResult
    student: bool


def check_options(resume_dir: str | None, backend: str | None, address: str | None, changed: Iterable[str]) -> None:
    """Flags that cannot go together, refused before any work (ConfigError): ``--address`` but for
    RLlib; with ``--resume``, any of ``changed`` (the options given besides --steps), since a resumed
    run keeps the config it was started with."""
    if address and (backend or (resume_dir and run_backend(resume_dir))) != "rllib":
        raise ConfigError("--address: only --backend rllib runs on a cluster")
    changed = list(changed)
    if resume_dir and changed:  # a resumed run keeps its own config: say so rather than ignore the option
        options = ", ".join(f"--{name.replace('_', '-')}" for name in changed)
        raise ConfigError(
            f"--resume continues a run with the config it was started with; {options} cannot "
            "change on resume (allowed with --resume: --steps, or --rounds for a student, to move the run's end)"
        )


def new_run_dir() -> str:
    """A new run's folder when none is named: runs/run-<date>-<time>."""
    return time.strftime("runs/run-%Y%m%d-%H%M%S")


def step_note(config: Config) -> str:
    """The unit of a progress line's steps: 'steps: gait decisions of 0.1 s' or 'steps: control steps of 0.02 s'."""
    agent, physics = config.agent, config.physics
    if agent.action_mode in ("gait", "discrete"):
        return f"steps: gait decisions of {agent.decision_interval:g} s"
    return f"steps: control steps of {physics.timestep * physics.action_repeat:g} s"


def step_unit(config: Config) -> str:
    """What a training step counts in a run of this config: agent decisions or control steps."""
    agent = config.agent
    if agent.action_mode in ("gait", "discrete"):
        return f"agent decisions (of {agent.decision_interval:g} s each)"
    physics = config.physics
    return f"agent decisions (control steps of {physics.timestep * physics.action_repeat:g} s)"


def steps_done(resume_dir: str | None) -> int:
    """The steps a run to be resumed has done (at its newest saved point); 0 for a new run."""
    if not resume_dir:
        return 0
    saved = RunFolder(resume_dir).saved() if Path(resume_dir).is_dir() else []
    return max(int(RunFolder._step_of(saved[0], unreadable=0)), 0) if saved else 0


def train_run(
    run_dir: str,
    config: Config | None,
    *,
    resume: bool = False,
    backend: str | None = None,
    total_steps: int | None = None,
    rounds: int | None = None,
    address: str | None = None,
    trust_model: bool = False,
    progress_every: float | None = None,
    display: Display = quietly,
    say: Callable[[str], None] = print,
) -> Trained:
    """Trains a new run in ``run_dir`` with ``config`` (a resolved config), or resumes the run there
    (``resume``; ``config`` None: the run's own, and its own backend; ``total_steps`` moves its end,
    or ``rounds`` a DAgger student's).

    The trainer: a DAgger student when the config names a teacher (train.teacher; stable-baselines3
    only, its budget in rounds, not steps); else PPO on RLlib for ``backend`` 'rllib' (on the Ray
    cluster at ``address`` if given), on stable-baselines3 otherwise. ``display`` shows the progress
    (a :class:`aaai.train.training.Progress` of steps, a line every ``progress_every`` seconds when
    it writes lines). ``trust_model``: a resume loads the run's checkpoint with its library's own
    loader (which unpickles it).
    """
    run_config = config or load_config(RunFolder(run_dir).read_config())
    total = total_steps or run_config.train.total_steps
    use_rllib = (run_backend(run_dir) if resume else backend) == "rllib"
    if use_rllib and run_config.train.init_from:
        raise ConfigError(
            f"--init-from: got {run_config.train.init_from!r} with --backend rllib, whose network (an RLlib "
            "RLModule) a stable-baselines3 model's weights do not fit, a recurrent student's LSTM least of all; "
            "allowed: --backend sb3 (PPO, or RecurrentPPO for a recurrent student)"
        )
    if run_config.train.teacher == "none" and run_config.train.student_policy != "mlp":
        raise ConfigError(
            f"config key 'train.student_policy': got {run_config.train.student_policy!r} for a PPO run; allowed: "
            "mlp, or a student of a teacher (train.teacher: reference). A PPO run started --init-from a "
            "recurrent student is recurrent by itself"
        )
    if run_config.train.teacher == "none" and run_config.train.dagger_data_from:
        raise ConfigError(
            f"config key 'train.dagger_data_from': got {run_config.train.dagger_data_from!r} for a PPO run; allowed: "
            "null, or a student of a teacher (train.teacher: reference or search), which starts from those rounds"
        )
    if run_config.train.teacher == "none" and rounds is not None:
        raise ConfigError(
            f"--rounds: got {rounds} for a PPO run, whose budget is steps; allowed: --steps, or --rounds for a "
            "student of a teacher (train.teacher: reference or search)"
        )
    if run_config.train.teacher != "none":
        if run_config.train.max_minutes:
            raise ConfigError(
                f"config key 'train.max_minutes': got {run_config.train.max_minutes:g} for a student of a teacher, "
                "whose budget is rounds of DAgger; allowed: 0 (set train.dagger_iterations and train.dagger_episodes)"
            )
        if use_rllib:
            raise ConfigError("--teacher: a student is trained with stable-baselines3 (--backend sb3)")
        if total_steps is not None:
            raise ConfigError(
                f"--steps: got {total_steps} for a student of a teacher, whose budget is rounds of DAgger, "
                "not steps; allowed: no --steps (set train.dagger_iterations and train.dagger_episodes)"
            )
        from aaai.train.student import train_student

        return Trained(
            train_student(run_dir, config, resume=resume, say=say, rounds=rounds if resume else None), student=True
        )
    report = Progress(
        total,
        done=steps_done(run_dir if resume else None),
        every=progress_every,
        label=f"training ({step_note(run_config)})",
    )
    result: TrainResult
    with display(report) as update:
        if use_rllib:
            result = train_rllib(
                run_dir,
                config,
                resume=resume,
                progress=update,
                address=address,
                total_steps=total_steps if resume else None,
                say=say,
                trust=trust_model,
            )
        else:
            result = train(
                run_dir,
                config,
                resume=resume,
                progress=update,
                total_steps=total_steps if resume else None,
                say=say,
                on_episodes=report.on_episodes,
                trust=trust_model,
            )
    return Trained(result, student=False)
