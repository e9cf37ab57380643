"""The Ray eval backend (aaai/scoring/distributed.py) against the local one (aaai.scoring.evaluation.evaluate).

Most tests share one two-node Ray cluster on this machine (``ray.cluster_utils.Cluster``, two nodes of
one CPU each), started once for the module in a private Ray temp folder (so that no other
``ray.init()`` on this machine finds and joins it) and shut down after it; every eval connects to it
with ``address=`` and disconnects when it ends. One test starts and stops a local Ray of its own.
"""

from __future__ import annotations

import csv
import os
import shutil
import tempfile
import textwrap
import time
from pathlib import Path

import pytest
from conftest import processes_holding

pytest.importorskip("ray", reason="needs the ray extra, which make test installs")

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai.scoring.distributed import evaluate_on_ray  # noqa: E402
from aaai.scoring.evaluation import Cell, evaluate  # noqa: E402

# Random actions like the random policy, but the worker process running the episode of KILL_SEED
# kills itself (SIGKILL: no clean-up, as the OOM killer) at step KILL_STEP, once: the first attempt
# leaves a marker file (holding its pid) in AAAI_TEST_KILL_DIR.
KILL_SEED, KILL_STEP = 22, 30
KILL_POLICY = """
import os, signal
from pathlib import Path

from aaai.scoring.policies import RandomPolicy


class KillOnce(RandomPolicy):
    def reset(self, seed):
        super().reset(seed)
        self.seed, self.steps = seed, 0

    def __call__(self, observation):
        self.steps += 1
        marker = Path(os.environ["AAAI_TEST_KILL_DIR"]) / f"killed_{{self.seed}}"
        if self.seed == {seed} and self.steps == {step} and not marker.exists():
            marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
        return super().__call__(observation)
"""
CONFIG = load_config(None, max_steps=100)  # short episodes: these tests compare backends, not policies


def cells(*spec):
    return [Cell(level, difficulty, list(seeds)) for level, difficulty, seeds in spec]


def table(path: Path, keep_order: bool = True) -> list[list[str]]:
    """A scoreboard's rows without the timing column (header included)."""
    with open(path, newline="") as handle:
        rows = [row[:-1] for row in csv.reader(handle)]
    return rows if keep_order else [rows[0]] + sorted(rows[1:])


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie (exited, not yet reaped) is not running
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def wait_gone(pids, seconds: float = 20.0) -> set[int]:
    deadline = time.time() + seconds
    while (left := {pid for pid in pids if alive(pid)}) and time.time() < deadline:
        time.sleep(0.2)
    return left


class TwoNodes:
    def __init__(self, cluster, helpers: Path, kill_dir: Path):
        self.cluster, self.helpers, self.kill_dir = cluster, helpers, kill_dir
        self.address = cluster.address
        self.node_ids = {node.node_id for node in cluster.list_all_nodes()}
        self.worker_pids: set[int] = set()

    def record(self, rows, where):
        self.worker_pids.add(where["pid"])


@pytest.fixture(scope="module")
def two_nodes(tmp_path_factory):
    from ray.cluster_utils import Cluster

    folder = tmp_path_factory.mktemp("ray_eval")
    helpers, kill_dir = folder / "helpers", folder / "killed"
    helpers.mkdir()
    kill_dir.mkdir()
    (helpers / "aaai_test_kill.py").write_text(textwrap.dedent(KILL_POLICY.format(seed=KILL_SEED, step=KILL_STEP)))
    ray_tmp = tempfile.mkdtemp(prefix="aaairay", dir="/tmp")  # short: Ray's socket paths live here
    changes = {
        "RAY_AUTH_MODE": "disabled",
        "RAY_TMPDIR": ray_tmp,
        "AAAI_TEST_KILL_DIR": str(kill_dir),
        "PYTHONPATH": os.pathsep.join(filter(None, [str(helpers), os.environ.get("PYTHONPATH")])),
    }
    saved = {key: os.environ.get(key) for key in changes}
    os.environ.update(changes)  # the nodes' processes (and their workers) inherit these
    cluster = None
    try:
        cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
        cluster.add_node(num_cpus=1)
        cluster.wait_for_nodes()
        nodes = TwoNodes(cluster, helpers, kill_dir)
        system_pids = {
            info.process.pid
            for node in cluster.list_all_nodes()
            for infos in node.all_processes.values()
            for info in infos
        }
        yield nodes
    finally:
        if cluster is not None:
            cluster.shutdown()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        shutil.rmtree(ray_tmp, ignore_errors=True)
    left = wait_gone(system_pids | nodes.worker_pids | processes_holding(ray_tmp))
    assert not left, f"Ray processes of the test cluster still running after its shutdown: {sorted(left)}"


@pytest.fixture(scope="module")
def ppo_model(tmp_path_factory):
    """An untrained stable-baselines3 PPO model (deterministic actions, shipped to the workers as bytes)."""
    pytest.importorskip("stable_baselines3", reason="needs the train extra, which make test installs")
    from stable_baselines3 import PPO

    from aaai.config import env_part
    from aaai.env import AnimalAIEnv

    env = AnimalAIEnv(config=env_part(CONFIG, shaping=0.0))
    try:
        model = PPO(
            "MultiInputPolicy",
            env,
            n_steps=64,
            batch_size=64,
            seed=0,
            device="cpu",
            policy_kwargs={"net_arch": [16, 16]},
        )
        path = tmp_path_factory.mktemp("model") / "model.zip"
        model.save(path)
    finally:
        env.close()
    return str(path)


@pytest.mark.parametrize("policy", ["random", "reference", "model"])
def test_scoreboard_equals_the_local_one(two_nodes, ppo_model, tmp_path, policy):
    policy = ppo_model if policy == "model" else policy
    plan = cells((0, 0, [11, 12]), (0, 1, [13]), (1, 0, [14]))
    local = evaluate(policy, plan, tmp_path / "local.csv", CONFIG)
    on_ray = evaluate_on_ray(
        policy, plan, tmp_path / "ray.csv", CONFIG, address=two_nodes.address, on_task=two_nodes.record
    )
    assert table(tmp_path / "ray.csv") == table(tmp_path / "local.csv")  # same rows, same order, timing aside
    assert [{k: v for k, v in row.items() if k != "wall_seconds"} for row in on_ray] == [
        {k: v for k, v in row.items() if k != "wall_seconds"} for row in local
    ]
    assert (tmp_path / "ray_scored_with.json").read_text() == (tmp_path / "local_scored_with.json").read_text()


def test_work_runs_on_both_nodes(two_nodes, tmp_path):
    nodes = []

    def record(rows, where):
        two_nodes.record(rows, where)
        nodes.append(where["node_id"])

    rows = evaluate_on_ray(
        "random",
        cells((0, 0, range(31, 37))),
        tmp_path / "board.csv",
        CONFIG,
        address=two_nodes.address,
        on_task=record,
    )
    assert len(rows) == len(nodes) == 6
    assert set(nodes) == two_nodes.node_ids and len(two_nodes.node_ids) == 2


def test_resume_scores_only_the_missing_episodes(two_nodes, tmp_path):
    plan = cells((0, 0, [41, 42, 43]), (0, 2, [44, 45]))
    board = tmp_path / "board.csv"
    evaluate_on_ray("random", plan, board, CONFIG, address=two_nodes.address, on_task=two_nodes.record)
    whole = table(board)
    lines = board.read_text().splitlines(keepends=True)
    board.write_text("".join(lines[:3]) + lines[3][:20])  # header, two rows and a torn third (a kill mid-write)
    scored = []
    rows = evaluate_on_ray(
        "random",
        plan,
        board,
        CONFIG,
        address=two_nodes.address,
        on_episode=lambda row: scored.append((row["level"], row["difficulty"], row["seed"])),
        on_task=two_nodes.record,
    )
    assert sorted(scored) == [(0, 0, 43), (0, 2, 44), (0, 2, 45)]
    assert table(board) == whole and len(rows) == 5
    again = []
    evaluate_on_ray("random", plan, board, CONFIG, address=two_nodes.address, on_episode=again.append)
    assert again == [] and table(board) == whole  # nothing missing: nothing scored (Ray not even started)


def test_an_episode_whose_worker_is_killed_is_played_again(two_nodes, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(two_nodes.helpers))  # the driver checks that the policy imports
    plan = cells((0, 0, [21, KILL_SEED, 23]))
    where = {}

    def record(rows, info):
        two_nodes.record(rows, info)
        where.update({row["seed"]: info["pid"] for row in rows})

    rows = evaluate_on_ray(
        "aaai_test_kill:KillOnce", plan, tmp_path / "board.csv", CONFIG, address=two_nodes.address, on_task=record
    )
    marker = two_nodes.kill_dir / f"killed_{KILL_SEED}"
    assert marker.is_file(), "the first attempt never reached the kill"
    killed_pid = int(marker.read_text())
    assert not alive(killed_pid) and where[KILL_SEED] != killed_pid  # the retry ran in another process
    assert [int(row["seed"]) for row in rows] == [21, KILL_SEED, 23]  # once each
    # The killing policy acts as the random policy does: the retried episode is the one it would have been.
    evaluate("random", plan, tmp_path / "random.csv", CONFIG)
    assert table(tmp_path / "board.csv") == table(tmp_path / "random.csv")


def test_bad_input_is_refused_before_ray_starts(tmp_path):
    import socket

    with socket.socket() as free:  # a port nobody listens on
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    for policy, options, message in [
        ("no_such_module:make", {}, "cannot load"),
        (str(tmp_path / "missing.zip"), {}, "does not exist"),
        ("nonsense", {}, "allowed"),
        ("random", {"workers": 0}, "workers"),
        ("random", {"address": f"127.0.0.1:{port}"}, "no Ray cluster answers"),
    ]:
        started = time.time()
        with pytest.raises(ConfigError, match=message):
            evaluate_on_ray(policy, cells((0, 0, [1])), tmp_path / f"board_{len(message)}.csv", CONFIG, **options)
        assert time.time() - started < 10


def test_without_an_address_a_local_ray_is_started_and_stopped(tmp_path):
    import ray

    pids = set()
    before = os.environ.get("RAY_AUTH_MODE")
    rows = evaluate_on_ray(
        "random",
        cells((0, 0, [51, 52, 53])),
        tmp_path / "ray.csv",
        CONFIG,
        workers=2,
        on_task=lambda rows, where: pids.add(where["pid"]),
    )
    evaluate("random", cells((0, 0, [51, 52, 53])), tmp_path / "local.csv", CONFIG)
    assert len(rows) == 3 and table(tmp_path / "ray.csv") == table(tmp_path / "local.csv")
    assert not ray.is_initialized()
    assert not wait_gone(pids), "the local Ray's workers outlived ray.shutdown()"
    assert before is not None or os.environ.get("RAY_AUTH_MODE") == "disabled"


def test_repeated_seeds_score_once_on_both_backends(two_nodes, tmp_path):
    """Guards the episode plan both backends play: seeds [5, 5, 6] are two rows on Ray as locally."""
    rows = evaluate_on_ray("random", cells((0, 0, [5, 5, 6])), tmp_path / "ray.csv", CONFIG, address=two_nodes.address)
    evaluate("random", cells((0, 0, [5, 5, 6])), tmp_path / "local.csv", CONFIG)
    assert [row["seed"] for row in rows] == ["5", "6"]
    assert table(tmp_path / "ray.csv") == table(tmp_path / "local.csv")


def test_the_eval_command_scores_the_same_on_ray(two_nodes, tmp_path):
    """`aaai eval --backend ray` as a user types it, on the cluster by --address: the same scoreboard as
    --backend local. (Starting and stopping a local Ray is the test above without an address.)"""
    from click.testing import CliRunner

    from aaai_cli.main import cli

    short = tmp_path / "short.yaml"
    short.write_text("episode:\n  max_steps: 100\n")  # as CONFIG: these tests compare backends, not policies
    args = ["eval", "--policy", "random", "-k", "2", "--levels", "0-1", "--difficulty", "0", "--config", str(short)]
    for backend in ("local", "ray"):
        extra = ["--address", two_nodes.address] if backend == "ray" else []
        result = CliRunner().invoke(
            cli, [*args, "--backend", backend, *extra, "--out", str(tmp_path / f"{backend}.csv")]
        )
        assert result.exit_code == 0, result.output[-3000:]
    import ray

    assert not ray.is_initialized()  # the eval left the cluster it joined

    def rows(name):
        with open(tmp_path / name) as handle:
            return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in csv.DictReader(handle)]

    assert rows("ray.csv") == rows("local.csv") and len(rows("ray.csv")) == 4
    record = (tmp_path / "ray_scored_with.json").read_text()
    assert record == (tmp_path / "local_scored_with.json").read_text()
