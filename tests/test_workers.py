"""Worker processes that step several environments each (aaai.train.workers): the same episodes as in
one process, one clear error when a process dies, no process left after closing."""

import os
import signal

import numpy as np
import pytest

from aaai.config import load_config
from aaai.train.curriculum import Curriculum
from aaai.train.vector import CurriculumVecEnv, group_processes
from aaai.train.workers import WorkerLost, WorkerVecEnv

CONFIG = dict(rays=False, max_steps=10, levels="0-1", difficulties="0-1")


def _vec(asynchronous: bool, num_envs: int = 4, processes: int = 2) -> CurriculumVecEnv:
    config = load_config(num_envs=num_envs, processes=processes, **CONFIG)
    return CurriculumVecEnv(config, Curriculum.from_config(config), num_envs, asynchronous=asynchronous)


def _play(vec: CurriculumVecEnv, steps: int) -> tuple[list[dict], list]:
    rng = np.random.default_rng(7)
    observations, episodes = [vec.reset()], []
    for _ in range(steps):
        observation, _, _, _, finished, final = vec.step(rng.uniform(-1, 1, (vec.num_envs, 8)).astype(np.float32))
        observations += [observation, *final.values()]
        episodes += finished
    return observations, episodes


def test_two_processes_of_two_give_the_episodes_of_one_process_and_end_when_closed():
    """The same seeds and actions give the same observations, ends and episode numbers, across the
    ends of episodes (10 steps) and the resets of some environments but not others."""
    runs = {}
    for asynchronous in (False, True):
        vec = _vec(asynchronous)
        try:
            if asynchronous:
                assert isinstance(vec.envs, WorkerVecEnv) and (vec.envs.workers, vec.envs.per_worker) == (2, 2)
                processes = vec.envs.processes
            runs[asynchronous] = _play(vec, 23)
        finally:
            vec.close()
    assert [process.exitcode for process in processes] == [0, 0]  # closing ended every worker process
    (sync_obs, sync_episodes), (async_obs, async_episodes) = runs[False], runs[True]
    assert len(sync_obs) == len(async_obs)
    assert all(np.array_equal(a[key], b[key]) for a, b in zip(sync_obs, async_obs) for key in a)
    assert len(sync_episodes) == 8 and sync_episodes == async_episodes  # two ends each, numbers and all


def test_a_worker_process_that_dies_is_named_in_one_error_and_the_others_are_stopped():
    vec = _vec(True)
    try:
        vec.reset()
        processes = vec.envs.processes
        os.kill(processes[1].pid, signal.SIGKILL)
        processes[1].join(5)
        with pytest.raises(
            WorkerLost, match=r"worker process 1 of 2 \(pid \d+, environments 2 to 3\) was killed by SIGKILL"
        ):
            vec.step(np.zeros((4, 8), np.float32))
        assert not any(process.is_alive() for process in processes)
    finally:
        vec.close()


def test_the_environments_are_shared_out_evenly_over_at_most_the_processes_asked():
    assert group_processes(load_config(num_envs=8, processes=2).train, 8) == 2
    assert group_processes(load_config(num_envs=8, processes=3).train, 8) == 2  # 3 does not divide 8
    assert group_processes(load_config(num_envs=6, processes=0).train, 6, cores=4) == 3
    assert group_processes(load_config(num_envs=2, processes=0).train, 2, cores=16) == 2
    with pytest.raises(ValueError, match="allowed: a divisor of 4"):
        WorkerVecEnv([lambda: None] * 4, 3)


def test_aaai_train_names_the_lost_worker_in_one_line_and_how_to_resume(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from aaai_cli.main import cli

    def lost(self, actions):
        raise WorkerLost("worker process 1 of 2 (pid 4242, environments 2 to 3) was killed by SIGKILL")

    monkeypatch.setattr(CurriculumVecEnv, "step", lost)
    run = tmp_path / "run"
    result = CliRunner().invoke(cli, ["train", "--agent", "random", "--steps", "64", "--run", str(run)])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert f"killed by SIGKILL; the run keeps its last checkpoint: aaai train --resume {run}" in result.output
