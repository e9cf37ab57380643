"""`aaai eval --backend ray`: the scoreboard's episodes played as Ray tasks, on this machine or a cluster.

Scores exactly as :func:`aaai.evaluation.evaluate` does (the same ``run_episode`` on an environment
without shaping, the same policies, the same CSV and the same record beside it), but each episode is
a Ray task. A task builds its own environment and policy (kept for the next task in the same worker
process) and returns the episode's row; the driver appends rows to the CSV as they arrive (flushed
and fsynced per row) and, when all are in, rewrites the file atomically so that it reads as the
local backend's would: the rows that were there before, then this run's rows in cell and seed
order. An interrupted eval leaves every row that had arrived; running it again scores only the
missing (level, difficulty, seed) episodes and puts the killed run's rows and its own in that order
(a hidden ``.<out>.ray-unordered`` file beside the scoreboard says where they start), so the file
equals an uninterrupted run's. A task whose worker process dies (killed, out of
memory, its node lost) is run again (``max_retries``), so no episode is lost and none is written
twice.

A trained model is read once by the driver and shipped through Ray's object store, so the nodes of
a cluster need no shared file system; every node needs ``aaai`` (and, for models, the ``train``
extra) installed, and a ``module:callable`` policy must be importable there.

Ray's token authentication is opted out of (``RAY_AUTH_MODE=disabled``, unless the variable is set
already): otherwise ``ray.init`` writes a token to ``~/.ray/auth_token``. To join a cluster that
uses tokens, set ``RAY_AUTH_MODE=token`` yourself.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import tempfile
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from aaai.config import ConfigError, env_part
from aaai.evaluation import (
    COLUMNS,
    Cell,
    Scoreboard,
    check_record,
    columns_of,
    episode_plan,
    load_policy,
    policy_factory,
    policy_record,
    run_episode,
    scored_episodes,
    scoring_record,
    write_error,
)
from aaai.files import write_atomic
from aaai.ray_session import RaySession
from aaai.rllib_learner import run_backend
from aaai.runs import check_writable

DEFAULT_RETRIES = 3
BUILTIN_POLICIES = ("random", "reference", "gait")

Key = tuple[int, int, int]  # (level, difficulty, seed)


@dataclass(frozen=True)
class PolicySpec:
    """What a task needs to rebuild the policy: a name load_policy takes, or a model's bytes (by reference)."""

    name: str  # 'random', 'reference', 'gait', 'module:callable'; or 'model' with ``model`` set
    model_sha256: str | None = None
    model: Any = None  # [ObjectRef] of the model file's bytes (in a list: Ray resolves bare refs)
    trust: bool = False  # load the model with stable-baselines3's own loader (--trust-model)

    @property
    def key(self) -> str:
        return self.model_sha256 or self.name


def policy_spec(policy: str, put: Callable[[bytes], Any] | None = None, trust: bool = False) -> PolicySpec:
    """Resolves a --policy as load_policy would, in the driver; a bad one fails here, before any task.

    A model (a .zip or a run folder's newest model) is read once; ``put`` (ray.put) ships its bytes.
    """
    if policy in BUILTIN_POLICIES:
        return PolicySpec(policy)
    if Path(policy).is_dir() and run_backend(policy) == "rllib":
        raise ConfigError(
            f"--policy: {policy!r} is an RLlib run; --backend ray scores stable-baselines3 models, "
            "the built-in policies and module:callable; score an RLlib run with --backend local"
        )
    model = policy_record(policy, "list").get("model")  # the model file; a missing or damaged one is refused
    if model is not None:
        data = Path(model).read_bytes()
        return PolicySpec("model", hashlib.sha256(data).hexdigest(), [put(data) if put else data], trust)
    if Path(policy).is_dir():
        return PolicySpec("random")  # a run of the random agent (load_policy does the same)
    policy_factory(policy)  # importable here (it must be on every worker too)
    return PolicySpec(policy)


# --- in the worker processes -----------------------------------------------------------------
_WORKER: dict = {}  # the environment and policy of this worker process, kept between tasks


def _worker_env_and_policy(spec: PolicySpec, config: dict):
    import json

    key = (spec.key, json.dumps(config, sort_keys=True, default=str))
    if _WORKER.get("key") != key:
        from aaai.env import AnimalAIEnv

        if "env" in _WORKER:
            _WORKER.pop("env").close()
        _WORKER.clear()
        env = AnimalAIEnv(config=env_part(config, shaping=0.0))  # scores count the task's own reward
        if spec.name == "model":
            import ray

            data = spec.model[0]
            data = ray.get(data) if isinstance(data, ray.ObjectRef) else data
            with tempfile.TemporaryDirectory(prefix="aaai-model-") as folder:
                path = Path(folder) / "model.zip"
                path.write_bytes(data)
                policy = load_policy(str(path), env, trust=spec.trust)  # read whole at load: the file may go
        else:
            policy = load_policy(spec.name, env)
        _WORKER.update(key=key, env=env, policy=policy)
    return _WORKER["env"], _WORKER["policy"]


def play_episodes(spec: PolicySpec, config: dict, episodes: list[Key]) -> tuple[list[dict], dict]:
    """The body of a Ray task: plays ``episodes`` with the worker's environment and policy; returns
    their rows and where they ran (node id, host, pid)."""
    import socket

    import ray

    env, policy = _worker_env_and_policy(spec, config)
    rows = [run_episode(env, policy, level, difficulty, seed) for level, difficulty, seed in episodes]
    where = {"node_id": ray.get_runtime_context().get_node_id(), "host": socket.gethostname(), "pid": os.getpid()}
    return rows, where


# --- in the driver --------------------------------------------------------------------------
def _check_policy(policy: str, config: dict, trust: bool) -> None:
    """Loads a model policy once here, against the environment, so that a model that does not fit is
    refused before Ray starts and before any file is written."""
    if policy in BUILTIN_POLICIES or (":" in policy and not Path(policy).exists()):
        return
    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(config=env_part(config, shaping=0.0))
    try:
        load_policy(policy, env, trust=trust)
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
    policy_name: str,
    cells: list[Cell],
    output: Path,
    config: dict,
    address: str | None = None,
    workers: int = 2,
    on_episode: Callable[[dict], None] | None = None,
    record: dict | None = None,
    max_retries: int = DEFAULT_RETRIES,
    episodes_per_task: int = 1,
    on_task: Callable[[list[dict], dict], None] | None = None,
    trust: bool = False,
) -> list[dict]:
    """:func:`aaai.evaluation.evaluate` with its episodes played as Ray tasks; same arguments, same result.

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
    check_writable(output, "--out")
    output.parent.mkdir(parents=True, exist_ok=True)
    record = scoring_record(policy_name, record, config)
    check_record(output, record)
    rows = scored_episodes(output)  # also cuts a torn last line
    order: dict[Key, int] = {}  # every episode of the cells, in cell and seed order
    for cell in cells:
        for seed in cell.seeds:
            order.setdefault((int(cell.level), int(cell.difficulty), int(seed)), len(order))
    plan: list[Key] = episode_plan(cells, rows)
    settled = _settled_rows(output, len(rows))  # rows before them arrived in a Ray eval that was killed
    if not plan:
        return _put_in_order(output, rows, settled, order) if settled < len(rows) else rows
    policy_spec(policy_name)  # a bad policy is refused before Ray starts (the model is read again below)
    _check_policy(policy_name, config, trust)  # and a model that does not fit the environment, before any file
    finished: dict[Key, dict] = {}
    with RaySession(address, workers):
        import ray

        spec = policy_spec(policy_name, put=ray.put, trust=trust)
        config_ref = ray.put(config)
        task = ray.remote(play_episodes).options(
            num_cpus=1, max_retries=max_retries, retry_exceptions=False, scheduling_strategy="SPREAD"
        )
        chunks = deque(plan[i : i + episodes_per_task] for i in range(0, len(plan), episodes_per_task))
        window = 2 * max(1, int(ray.cluster_resources().get("CPU", workers)))
        pending: dict = {}
        write_atomic(_unordered_path(output), json.dumps({"settled_rows": settled}) + "\n")
        with Scoreboard(output, record, columns_of(output), list(rows), on_episode) as board:
            try:
                while chunks or pending:
                    while chunks and len(pending) < window:
                        chunk = chunks.popleft()
                        pending[task.remote(spec, config_ref, chunk)] = chunk
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
                        board.append(row)  # the record and header come with the first row
                        finished[(row["level"], row["difficulty"], row["seed"])] = row
                    if on_task:
                        on_task(new_rows, where)
            except BaseException:
                if not finished and settled == len(rows):  # nothing streamed: leave nothing behind
                    _unordered_path(output).unlink(missing_ok=True)
                raise
            finally:
                for ref in pending:  # an error or an interrupt: nothing more is started for this eval
                    ray.cancel(ref, force=True)
    new = [{k: str(v) for k, v in finished[key].items()} for key in plan]
    return _put_in_order(output, rows + new, settled, order)


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
