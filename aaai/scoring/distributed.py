"""`aaai eval --backend ray`: the scoreboard's episodes played as Ray tasks, on this machine or a cluster.

Scores with :func:`aaai.scoring.evaluation.score`, the loop the local eval uses (the same plan, record,
CSV and ``run_episode`` on an environment without shaping); only where the episodes run differs:
each is a Ray task. A task builds the resolved :class:`aaai.scoring.policies.Policy` and an environment
(kept for the next task in the same worker process) and returns the episode's row; the driver
appends rows to the CSV as they arrive (flushed and fsynced per row) and, when all are in,
rewrites the file atomically so that it reads as the local backend's would: the rows that were
there before, then this run's rows in cell and seed order. An interrupted eval leaves every row
that had arrived; running it again scores only the missing (level, difficulty, seed) episodes and
puts the killed run's rows and its own in that order (a hidden ``.<out>.ray-unordered`` file
beside the scoreboard says where they start), so the file equals an uninterrupted run's. A task
whose worker process dies (killed, out of memory, its node lost) is run again (``max_retries``),
so no episode is lost and none is written twice.

A trained model is read once by the driver and shipped through Ray's object store, so the nodes of
a cluster need no shared file system; every node needs ``aaai`` (and, for models, the ``train``
extra) installed, and a ``module:callable`` policy must be importable there.

Ray's token authentication is opted out of (``RAY_AUTH_MODE=disabled``, unless the variable is set
already): otherwise ``ray.init`` writes a token to ``~/.ray/auth_token``. To join a cluster that
uses tokens, set ``RAY_AUTH_MODE=token`` yourself.
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from collections import deque
from pathlib import Path
from typing import Callable, Generator

from aaai.config import Config, ConfigError, env_part
from aaai.files import write_atomic
from aaai.scoring.episodes import run_episode
from aaai.scoring.evaluation import score
from aaai.scoring.plan import Cell, episode_plan
from aaai.scoring.policies import Policy, as_policy
from aaai.scoring.ray_session import RaySession
from aaai.scoring.scoreboard import COLUMNS, columns_of, write_error

DEFAULT_RETRIES = 3

Key = tuple[int, int, int]  # (level, difficulty, seed)


# --- in the worker processes -----------------------------------------------------------------
_WORKER: dict = {}  # the environment and policy of this worker process, kept between tasks


def _worker_env_and_policy(policy: Policy, model: list, config: Config):
    key = (policy.key, json.dumps(config.to_dict(), sort_keys=True, default=str))
    if _WORKER.get("key") != key:
        from aaai.env import AnimalAIEnv

        if "env" in _WORKER:
            _WORKER.pop("env").close()
        _WORKER.clear()
        env = AnimalAIEnv(config=env_part(config, shaping=0.0))  # scores count the task's own reward
        if model:
            import ray

            data = model[0]
            data = ray.get(data) if isinstance(data, ray.ObjectRef) else data
            with tempfile.TemporaryDirectory(prefix="aaai-model-") as folder:
                path = Path(folder) / "model.zip"
                path.write_bytes(data)
                acting = policy.with_file(path).build(env)  # read whole at load: the file may go
        else:
            acting = policy.build(env)
        _WORKER.update(key=key, env=env, policy=acting)
    return _WORKER["env"], _WORKER["policy"]


def play_episodes(policy: Policy, model: list, config: Config, episodes: list[Key]) -> tuple[list[dict], dict]:
    """The body of a Ray task: plays ``episodes`` with the worker's environment and policy (the
    model's bytes, if any, come in ``model`` as [ObjectRef]: Ray resolves bare refs); returns their
    rows and where they ran (node id, host, pid)."""
    import socket

    import ray

    env, acting = _worker_env_and_policy(policy, model, config)
    rows = [run_episode(env, acting, level, difficulty, seed) for level, difficulty, seed in episodes]
    where = {"node_id": ray.get_runtime_context().get_node_id(), "host": socket.gethostname(), "pid": os.getpid()}
    return rows, where


# --- in the driver --------------------------------------------------------------------------
def _check_policy(policy: Policy, config: Config) -> None:
    """Loads a model policy once here, against the environment, so that a model that does not fit is
    refused before Ray starts and before any file is written."""
    if policy.kind != "model":
        return
    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        policy.build(env)
    finally:
        env.close()


def _format_rows(rows: list[dict], header: bool, columns: list[str] = COLUMNS) -> str:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns, extrasaction="ignore")
    if header:
        writer.writeheader()
    writer.writerows(rows)
    return text.getvalue()


def evaluate_on_ray(
    policy: Policy | str,
    cells: list[Cell],
    output: Path,
    config: Config,
    address: str | None = None,
    workers: int = 2,
    on_episode: Callable[[dict], None] | None = None,
    record: dict | None = None,
    max_retries: int = DEFAULT_RETRIES,
    episodes_per_task: int = 1,
    on_task: Callable[[list[dict], dict], None] | None = None,
    trust: bool = False,
) -> list[dict]:
    """:func:`aaai.scoring.evaluation.evaluate` with its episodes played as Ray tasks; same arguments, same result.

    ``address``: None starts a local Ray of ``workers`` CPUs for this call (and stops it after);
    an address ("host:port" of its head, or "auto") joins that cluster, whose CPUs then set the
    parallelism (``workers`` is not used). Each task plays ``episodes_per_task`` episodes (1: rows
    arrive one by one) and is retried up to ``max_retries`` times if its worker process dies.
    ``on_episode(row)`` is called for every new row as it is written (in the order they finish);
    ``on_task(rows, where)`` with each task's rows and where it ran ({node_id, host, pid}).
    Returns every row of the scoreboard (those there before, then this run's in cell and seed order),
    as strings, as ``evaluate`` does.
    """
    for name, value, least in (
        ("workers", workers, 1),
        ("episodes_per_task", episodes_per_task, 1),
        ("max_retries", max_retries, 0),
    ):
        if not isinstance(value, int) or value < least:
            raise ConfigError(f"{name}: got {value!r}; allowed: a whole number, {least} or more")
    output = Path(output)
    policy = as_policy(policy, trust)
    if policy.kind == "rllib":
        raise ConfigError(
            f"--policy: {policy.name!r} is an RLlib run; --backend ray scores stable-baselines3 models, "
            "the built-in policies and module:callable; score an RLlib run with --backend local"
        )
    order: dict[Key, int] = {}  # every episode of the cells, in cell and seed order
    for cell in cells:
        for seed in cell.seeds:
            order.setdefault((int(cell.level), int(cell.difficulty), int(seed)), len(order))
    before, settled = [0], [0]  # rows there before; how many of them are in their final order (not a killed run's)

    def plan(rows: list[dict]) -> list[Key]:
        before[0], settled[0] = len(rows), _settled_rows(output, len(rows))
        return episode_plan(cells, rows)

    def play(episodes: list[Key]) -> Generator[dict, None, None]:
        if not episodes:
            return
        _check_policy(policy, config)  # a model that does not fit the environment is refused before Ray starts
        with RaySession(address, workers):
            import ray

            model = [ray.put(Path(str(policy.file)).read_bytes())] if policy.kind == "model" else []
            config_ref = ray.put(config)
            task = ray.remote(play_episodes).options(
                num_cpus=1, max_retries=max_retries, retry_exceptions=False, scheduling_strategy="SPREAD"
            )
            chunks = deque(episodes[i : i + episodes_per_task] for i in range(0, len(episodes), episodes_per_task))
            window = 2 * max(1, int(ray.cluster_resources().get("CPU", workers)))
            pending: dict = {}
            streamed = 0
            write_atomic(_unordered_path(output), json.dumps({"settled_rows": settled[0]}) + "\n")
            try:
                while chunks or pending:
                    while chunks and len(pending) < window:
                        chunk = chunks.popleft()
                        pending[task.remote(policy, model, config_ref, chunk)] = chunk
                    ready, _ = ray.wait(list(pending), num_returns=1)
                    pending.pop(ready[0])
                    try:
                        new_rows, where = ray.get(ready[0])
                    except ray.exceptions.RayTaskError as error:
                        cause = error.cause
                        if isinstance(cause, ConfigError):
                            raise ConfigError(str(cause)) from None
                        raise
                    for row in new_rows:
                        yield row  # the scoreboard appends it (the record and header come with the first row)
                        streamed += 1
                    if on_task:
                        on_task(new_rows, where)
            except BaseException:
                if not streamed and settled[0] == before[0]:  # nothing streamed: leave nothing behind
                    _unordered_path(output).unlink(missing_ok=True)
                raise
            finally:
                for ref in pending:  # an error or an interrupt: nothing more is started for this eval
                    ray.cancel(ref, force=True)

    rows = score(policy, output, config, plan, play, record, on_episode)
    return _put_in_order(output, rows, settled[0], order) if settled[0] < len(rows) else rows


def _unordered_path(output: Path) -> Path:
    """Beside a scoreboard while a Ray eval streams rows into it in the order they finish: how
    many rows were there before (in their final order). Gone once the file is rewritten in order."""
    return output.with_name(f".{output.name}.ray-unordered")


def _settled_rows(output: Path, count: int) -> int:
    """How many of the scoreboard's ``count`` rows are in their final order: all, unless a Ray eval
    streaming rows into it was killed before it rewrote the file in order."""
    try:
        return min(count, int(json.loads(_unordered_path(output).read_text())["settled_rows"]))
    except (OSError, ValueError, KeyError, TypeError):
        return count


def _put_in_order(output: Path, rows: list[dict], settled: int, order: dict[Key, int]) -> list[dict]:
    """Rewrites the scoreboard atomically as the local backend would have it: the ``settled`` rows
    as they are, then the rest in this eval's cell and seed order (those of the rows streamed by an
    eval that was killed, then run again, included), and removes the unordered marker."""

    def place(row: dict) -> int:
        return order.get((int(row["level"]), int(row["difficulty"]), int(row["seed"])), -1)

    ordered = rows[:settled] + sorted(rows[settled:], key=place)  # stable: foreign rows first, as they came
    try:
        write_atomic(output, _format_rows(ordered, header=True, columns=columns_of(output)))
    except OSError as error:  # the rows stay as they arrived (each fsynced); only their order is not the local one
        raise ConfigError(write_error(output, error, len(rows))) from None
    _unordered_path(output).unlink(missing_ok=True)
    return ordered
