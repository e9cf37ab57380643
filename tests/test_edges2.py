"""Loose ends of safety: a resumed run's model within the same size budgets as a scored one, the
trusted path still checked, YAML read only through the project's reader, --init-from's carried
config compared, the play server's idle sessions and reloads, arena validation in linear time."""

from __future__ import annotations

import json
import re
import struct
import time
import zipfile
import zlib
from pathlib import Path

import pytest

from aaai.config import ConfigError, load_config


# --- 1. a run folder's model.zip on --resume: the size budgets of a scored model -------------------
def _zip_bomb(path: Path, mib: int, member: str = "policy.pth") -> Path:
    """A model zip whose ``member`` is ``mib`` MiB of zeros, deflated (a few kB on disk per MiB)."""
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = compressor.compress(bytes(1 << 20)) + compressor.flush(zlib.Z_FULL_FLUSH)
    stream = block * mib + zlib.compressobj(9, zlib.DEFLATED, -15).flush()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("data", "{}")
        archive.writestr(member, stream)
    raw = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo(member)
    struct.pack_into("<H", raw, info.header_offset + 8, zipfile.ZIP_DEFLATED)
    struct.pack_into("<I", raw, info.header_offset + 22, mib << 20)
    central = raw.index(b"PK\x01\x02")
    while raw[central + 46 : central + 46 + len(member)] != member.encode():
        central = raw.index(b"PK\x01\x02", central + 4)
    struct.pack_into("<H", raw, central + 10, zipfile.ZIP_DEFLATED)
    struct.pack_into("<I", raw, central + 24, mib << 20)
    path.write_bytes(bytes(raw))
    return path


def test_a_zip_bomb_in_a_run_folder_is_refused_on_resume_by_its_declared_size(tmp_path):
    from aaai.scoring.runs import RunFolder, model_problem

    run = RunFolder(tmp_path / "run")
    run.final.mkdir(parents=True)
    (run.final / "state.json").write_text(json.dumps({"step": 64, "curriculum": {}}))
    _zip_bomb(run.final / "model.zip", 2000)  # 2000 MiB inflated, 2 MB on disk
    start = time.perf_counter()
    problem = model_problem(run.final / "model.zip")
    assert time.perf_counter() - start < 0.5  # nothing inflated (testzip took 10 s on it)
    assert problem == "model.zip: member 'policy.pth' inflates to 2000.0 MiB; allowed: at most 640.0 MiB"
    told: list[str] = []
    with pytest.raises(ConfigError) as refused:
        run.resume_point(needs_model=True, say=told.append)
    message = str(refused.value)
    assert "\n" not in message and "final/model.zip" in message and "2000.0 MiB" in message, message
    assert told == [f"skipping final: {problem}; falling back to an older checkpoint"]


# --- 3. YAML only through aaai.safe_yaml -------------------------------------------------------------
def test_an_experiment_record_is_read_as_plain_yaml_only(tmp_path):
    from aaai.config import load_config
    from aaai.train.experiments import plan

    folder = tmp_path / "exp"
    folder.mkdir()
    canary = tmp_path / "canary"
    (folder / "experiment.yaml").write_text(f"config: !!python/object/apply:os.system ['touch {canary}']\n")
    with pytest.raises(ConfigError, match=r"experiment\.yaml.*line 1: the tag !!python/object/apply:os.system"):
        plan(folder, ["uniform"], [0], load_config({}), 1)
    (folder / "experiment.yaml").write_text("- a list\n")
    with pytest.raises(ConfigError, match=r"experiment\.yaml.*the top level must be a mapping"):
        plan(folder, ["uniform"], [0], load_config({}), 1)
    assert not canary.exists()


def test_no_module_reads_yaml_but_through_safe_yaml():
    package = Path(__file__).resolve().parent.parent / "aaai"
    reader = re.compile(r"(?<![\w.])yaml\.(?:safe_|full_|unsafe_)?load(?:_all)?\(|from yaml import .*load")
    found = [
        f"{path.relative_to(package)}: {hit.group(0)}"
        for path in sorted(package.rglob("*.py"))
        if path.name != "safe_yaml.py"
        for hit in reader.finditer(path.read_text())
    ]
    assert found == []


# --- 2. --trust-model lets pickles run, not bad weights or oversized networks pass ----------------
@pytest.fixture(scope="module")
def pendulum_model(tmp_path_factory) -> Path:
    """A tiny PPO model on Pendulum, saved by stable-baselines3 (loads only with trust or the registry)."""
    pytest.importorskip("stable_baselines3", reason="needs the train extra (stable-baselines3)")
    from stable_baselines3 import PPO

    path = tmp_path_factory.mktemp("trusted") / "pendulum.zip"
    PPO("MlpPolicy", "Pendulum-v1", n_steps=16, batch_size=16, device="cpu", policy_kwargs={"net_arch": [8]}).save(path)
    return path


def _rewrite(source: Path, target: Path, data=None, weights=None) -> Path:
    import io

    import torch

    with zipfile.ZipFile(source) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    if data is not None:
        parsed = json.loads(members["data"])
        data(parsed)
        members["data"] = json.dumps(parsed).encode()
    if weights is not None:
        state = torch.load(io.BytesIO(members["policy.pth"]), weights_only=True)
        weights(state)
        buffer = io.BytesIO()
        torch.save(state, buffer)
        members["policy.pth"] = buffer.getvalue()
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, blob in members.items():
            archive.writestr(name, blob)
    return target


def test_a_trusted_model_is_still_refused_for_nan_weights_or_a_network_beyond_the_limits(pendulum_model, tmp_path):
    import gymnasium as gym

    from aaai.scoring.model_io import load_for_training
    from aaai.scoring.policies import _trusted_load

    assert _trusted_load(pendulum_model).policy is not None  # trusted and sound: loads
    nan = _rewrite(pendulum_model, tmp_path / "nan.zip", weights=lambda s: s["log_std"].fill_(float("nan")))
    wide = _rewrite(pendulum_model, tmp_path / "wide.zip", data=lambda d: d["policy_kwargs"].update(net_arch=[12000]))
    huge = _rewrite(
        pendulum_model, tmp_path / "huge.zip", data=lambda d: d["policy_kwargs"].update(net_arch=[4096] * 6)
    )
    env = gym.make("Pendulum-v1")
    for path, words in (
        (nan, ["'log_std'", "NaN or infinite"]),
        (wide, ["width 12000", "1 to 4096"]),
        (huge, ["at least 167,772,160 parameters", "at most 64,000,000"]),
    ):
        for load in (_trusted_load, lambda p: load_for_training(p, env, trust=True)):
            with pytest.raises(ConfigError) as refused:
                load(path)
            message = str(refused.value)
            assert str(path) in message and "--trust-model" not in message, message
            for word in words:
                assert word in message, (word, message)
    env.close()


# --- 4. --init-from a model whose carried config is another environment's -----------------------
def test_init_from_a_model_of_another_environment_is_refused_naming_each_key(tmp_path):
    from click.testing import CliRunner

    from aaai.config import load_config
    from aaai.train.training import with_proprioception
    from aaai_cli.main import cli

    here = with_proprioception(load_config({}))
    mode = next(m for m in ("rotation", "velocity", "gait") if m != here.agent.action_mode)
    there = load_config(here, agent={"action_mode": mode}, sensors={"rays_flat": not here.sensors.rays_flat})
    source = tmp_path / "other.zip"
    with zipfile.ZipFile(source, "w") as archive:  # the weights are never reached: the config is checked first
        archive.writestr("data", "{}")
        archive.writestr("policy.pth", b"not read")
        archive.writestr("aaai_config.yaml", there.to_yaml())
    run = tmp_path / "tuned"
    args = ["train", "--init-from", str(source), "--levels", "0", "--difficulty", "0", "--steps", "64"]
    result = CliRunner().invoke(cli, [*args, "--envs", "1", "--run", str(run)])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    message = " ".join(result.output.split())
    assert f"--init-from: model file {str(source)!r} was trained in another environment" in message, message
    assert f"agent.action_mode: {mode!r} there, {here.agent.action_mode!r} here" in message, message
    assert f"sensors.rays_flat: {not here.sensors.rays_flat} there, {here.sensors.rays_flat} here" in message
    assert "sensors.camera_resolution" not in message and not run.exists()


# --- 5. the play server: a reload takes its session over; an idle session is abandoned ------------
def test_a_reload_takes_its_session_over_and_an_idle_session_frees_its_world(tmp_path):
    from contextlib import ExitStack

    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from aaai.scoring.evaluation import Cell
    from aaai.tools.play.server import TAKEN_OVER, Server
    from aaai.tools.play.session import PlaySettings, abandoned_path

    config = load_config(None, camera=True, action_mode="gait", decision_interval=0.02, max_steps=400)
    settings = PlaySettings(
        config=config,
        cells=[Cell(0, 0, [0])],
        output=str(tmp_path / "human_{player}.csv"),
        between_seconds=0.0,
        grace_seconds=0.0,
        idle_seconds=2.0,  # long enough for the takeover below on a loaded machine, short for the test
    )
    server = Server(settings, port=0).start()
    origin = server.url.split("/?")[0].rstrip("/")

    def page(stack):
        ws = stack.enter_context(connect(server.url.replace("http", "ws") + "ws", origin=origin, max_size=None))
        assert json.loads(ws.recv(5))["type"] == "hello"
        return ws

    def until(ws, wanted, timeout=10.0) -> dict:
        """Reads (acknowledging frames) until a message for which ``wanted`` holds."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                message = ws.recv(0.2)
            except TimeoutError:
                continue
            if isinstance(message, bytes):
                continue
            data = json.loads(message)
            if data["type"] == "frame":
                ws.send(json.dumps({"type": "ack", "frame": data["frame"]}))
            if wanted(data):
                return data
        raise AssertionError("timed out")

    try:
        with ExitStack() as stack:
            old = page(stack)
            old.send(json.dumps({"type": "join", "player": "ann"}))
            token = until(old, lambda m: m["type"] == "joined")["token"]
            until(old, lambda m: m.get("phase") == "ready" and m["accepts_start"])
            new = page(stack)  # the reloaded page, while the old socket is still open
            new.send(json.dumps({"type": "join", "player": "ann", "token": token}))
            assert until(new, lambda m: m["type"] in ("joined", "error"))["type"] == "joined"
            new.send(json.dumps({"type": "key", "key": "ArrowUp", "down": True}))  # the new page drives
            told = until(old, lambda m: m["type"] == "error")["message"]
            assert told == "player 'ann' was taken over by another page (a reload or a duplicated tab)"
            with pytest.raises(ConnectionClosed) as closed:
                until(old, lambda m: False)
            assert closed.value.rcvd is not None and closed.value.rcvd.code == TAKEN_OVER
            until(new, lambda m: m.get("phase") == "running")
            session = server.registry.sessions["ann"]
            assert session.attached and server.registry.live() == 1  # the old socket's close detached nothing
            # no key for --idle seconds: the battery is abandoned and its environment closed
            ended = until(new, lambda m: m.get("phase") == "abandoned")
            assert ended["message"] == "abandoned: no key was pressed for 2 seconds (--idle)"
            assert session.done.wait(5) and session.env is None and server.registry.live() == 0
            assert abandoned_path(tmp_path / "human_ann.csv").is_file()
    finally:
        server.stop()


# --- 6. arena validation in time linear in its objects --------------------------------------------
def _crowded_spec(n: int, seed: int, size: float = 60.0):
    """A spec of ``n`` objects thrown at random into a small arena: walls, tunnels and ramps (some
    turned, some tall, some very long), food on the floor, on top of solids, in the air, over holes
    and cutting into solids, so that every kind of food problem occurs."""
    import numpy as np

    from aaai.spec import AgentPose, LevelSpec, ObjectSpec

    rng = np.random.default_rng(seed)
    objects = []
    for _ in range(n):
        x, y = rng.uniform(-size / 2, size / 2, 2)
        pick = rng.integers(6)
        if pick == 0:
            length = float(rng.choice([1.0, 3.0, min(size * 1.5, 90.0)]))
            objects.append(ObjectSpec("wall", "box", (x, y, 1.0), (length, 1.0, 2.0), float(rng.uniform(0, 3.2))))
        elif pick == 1:
            objects.append(ObjectSpec("tunnel", "box", (x, y, 2.0), (6.0, 8.0, 4.0), float(rng.uniform(0, 3.2))))
        elif pick == 2:
            objects.append(ObjectSpec("ramp", "box", (x, y, 1.0), (4.0, 3.0, 2.0), float(rng.uniform(0, 3.2))))
        else:
            z = float(rng.choice([0.5, 2.5, 1.7, 4.0]))  # the floor, on top of a 2-high solid, cutting in, the air
            objects.append(ObjectSpec("food_yellow", "sphere", (x, y, z), (1.0, 1.0, 1.0)))
    holes = tuple({(int(i), int(j)) for i, j in rng.integers(0, 8, (10, 2))})
    return LevelSpec(0, "crowded", 0, seed, AgentPose(0.0, 0.0, 0.0), tuple(objects), (size, size), tiles=(8, 8),
                     holes=holes)  # fmt: skip


def test_food_checks_find_the_same_problems_as_against_every_solid(monkeypatch):
    from aaai.levels import validate

    def problems(spec) -> list[list[str]]:
        index = validate.Solids(spec)
        return [validate.food_problems(spec, food, index) for food in spec.foods]

    specs = [_crowded_spec(n, seed) for n, seed in ((30, 0), (120, 1), (250, 2))]
    found = [problems(spec) for spec in specs]
    every = [problem for each in found for foods in each for problem in foods]
    assert any("cuts into" in p for p in every) and any("not on solid ground" in p for p in every)
    monkeypatch.setattr(validate.Solids, "near", lambda self, quad: list(range(len(self.pieces))))  # every solid
    assert found == [problems(spec) for spec in specs]


def test_an_arena_of_1000_objects_checks_each_food_against_the_solids_near_it(monkeypatch):
    from aaai.levels import validate

    calls = []
    overlap = validate.footprints_overlap
    monkeypatch.setattr(validate, "footprints_overlap", lambda *a, **k: calls.append(1) or overlap(*a, **k))
    spec = _crowded_spec(1000, 3, size=400.0)
    start = time.perf_counter()
    index = validate.Solids(spec)  # what check() makes, then the two steps that were n**2
    validate.overlapping_solids(spec, index)
    for food in spec.foods:
        validate.food_problems(spec, food, index)
    foods, pieces = len(spec.foods), len(index.pieces)
    assert foods > 400 and pieces > 400
    assert len(calls) < 20 * (foods + pieces), (len(calls), foods * pieces)  # against every solid: foods x pieces
    assert time.perf_counter() - start < 5
    calls.clear()
    validate.check(spec, require_food=False)  # and check() uses them so
    assert len(calls) < 20 * (foods + pieces)
