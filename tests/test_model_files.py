"""Model files and the signing key are safe: a model file is data of bounded size whose network is
sized and checked before it is built; every bad file gets one line naming it and the problem; the
RLlib signing key is made whole or not at all, and a key anyone could guess or read is refused."""

import errno
import io
import json
import os
import resource
import struct
import time
import zipfile
import zlib
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

pytest.importorskip("stable_baselines3", reason="needs the train extra")

import torch  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.files import folder_sha256  # noqa: E402
from aaai.scoring import model_archive, rllib_checkpoints  # noqa: E402
from aaai.scoring.evaluation import record_path  # noqa: E402
from aaai.scoring.policies import ModelPolicy  # noqa: E402
from aaai.train.training import with_proprioception  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

SHORT = {"episode": {"max_steps": 15}, "train": {"net_width": 32, "n_steps": 64, "batch_size": 32, "n_epochs": 1}}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("model_files")


@pytest.fixture(scope="module")
def config_file(folder) -> Path:
    path = folder / "short.yaml"
    path.write_text(yaml.safe_dump(SHORT))
    return path


@pytest.fixture(scope="module")
def model(folder) -> Path:
    """An untrained PPO saved as `aaai train` saves one, for the env of SHORT (a bare .zip)."""
    from stable_baselines3 import PPO

    env = AnimalAIEnv(config=load_config(SHORT))
    ppo = PPO("MultiInputPolicy", env, n_steps=64, batch_size=32, device="cpu", seed=0,
              policy_kwargs={"net_arch": [32, 32], "log_std_init": -1.0})  # fmt: skip
    env.close()
    ppo.save(folder / "good.zip")
    return folder / "good.zip"


@pytest.fixture(scope="module")
def start_model(folder) -> Path:
    """A model that fits a new run of SHORT (with training's extra body senses): for --init-from."""
    from stable_baselines3 import PPO

    env = AnimalAIEnv(config=with_proprioception(load_config(SHORT)))
    ppo = PPO("MultiInputPolicy", env, n_steps=64, device="cpu", policy_kwargs={"net_arch": [32, 32]})
    env.close()
    ppo.save(folder / "start.zip")
    return folder / "start.zip"


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


def _write(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, blob in members.items():
            archive.writestr(name, blob)
    return path


def _with_data(source: Path, target: Path, change) -> Path:
    members = _members(source)
    data = json.loads(members["data"])
    change(data)
    members["data"] = json.dumps(data).encode()
    return _write(target, members)


def _with_state(source: Path, target: Path, change) -> Path:
    members = _members(source)
    state = torch.load(io.BytesIO(members["policy.pth"]), weights_only=True)
    change(state)
    buffer = io.BytesIO()
    torch.save(state, buffer)
    members["policy.pth"] = buffer.getvalue()
    return _write(target, members)


def _eval(*args):
    return CliRunner().invoke(cli, ["eval", "--levels", "0", "--difficulty", "0", "-k", "1", *map(str, args)])


def _refused_in_one_line(result, *words: str, trust: bool = False) -> str:
    """The command was refused (exit 2) with one message naming ``words``, no traceback, and
    ``--trust-model`` named only where trust is the cause."""
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    message = " ".join(result.output.split())
    assert "Traceback" not in result.output
    for word in words:
        assert word in message, (word, message)
    assert ("--trust-model" in message) == trust, message
    return message


# --- 1. the signing key -------------------------------------------------------------------
@pytest.fixture
def key(tmp_path, monkeypatch) -> Path:
    path = tmp_path / "keys" / "checkpoint.key"
    monkeypatch.setenv("AAAI_CHECKPOINT_KEY", str(path))
    return path


def _checkpoint(tmp_path: Path) -> Path:
    checkpoint = tmp_path / "final" / "rllib"
    checkpoint.mkdir(parents=True)
    (checkpoint / "module_state.pkl").write_bytes(b"weights")
    return checkpoint


def test_an_empty_key_is_refused_naming_it_and_a_signature_forged_with_it_loads_nothing(key, tmp_path):
    import hashlib
    import hmac

    key.parent.mkdir()
    key.touch(mode=0o600)  # what a full disk left behind before keys were written whole
    checkpoint = _checkpoint(tmp_path)
    forged = hmac.new(b"", folder_sha256(checkpoint).encode(), hashlib.sha256).hexdigest()
    (checkpoint.parent / rllib_checkpoints.SIGNATURE).write_text(forged + "\n")
    with pytest.raises(ConfigError) as refused:
        rllib_checkpoints.check_rllib_checkpoint(checkpoint)
    message = str(refused.value)
    assert str(key) in message and "0 bytes" in message and "at least 32" in message and "Delete" in message
    with pytest.raises(ConfigError, match="0 bytes"):
        rllib_checkpoints.sign_checkpoint(checkpoint)  # nothing is signed with it either
    key.write_bytes(b"x" * 31)
    with pytest.raises(ConfigError, match="31 bytes"):
        rllib_checkpoints.sign_checkpoint(checkpoint)
    key.unlink()  # the fix the message gives: a new key is made, and signs
    rllib_checkpoints.sign_checkpoint(checkpoint)
    rllib_checkpoints.check_rllib_checkpoint(checkpoint)


def test_a_key_others_can_read_is_refused_naming_the_chmod_fix(key, tmp_path):
    checkpoint = _checkpoint(tmp_path)
    rllib_checkpoints.sign_checkpoint(checkpoint)
    key.chmod(0o644)
    with pytest.raises(ConfigError) as refused:
        rllib_checkpoints.check_rllib_checkpoint(checkpoint)
    assert "0644" in str(refused.value) and f"chmod 600 {str(key)!r}" in str(refused.value)
    key.chmod(0o600)
    rllib_checkpoints.check_rllib_checkpoint(checkpoint)


def test_rllib_training_with_a_key_that_cannot_sign_is_refused_before_its_run_folder(key, tmp_path):
    key.parent.mkdir()
    key.write_bytes(bytes(64))
    key.chmod(0o640)
    run = tmp_path / "run"
    result = CliRunner().invoke(cli, ["train", "--backend", "rllib", "--steps", "64", "--run", str(run)])
    _refused_in_one_line(result, str(key), "mode 0640", "chmod 600")
    assert not run.exists()


def test_a_full_disk_while_the_key_is_made_leaves_no_key_and_the_next_run_makes_a_whole_one(key, monkeypatch):
    real = os.fsync

    def full(descriptor):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(ConfigError, match="No space left.*nothing was written"):
        rllib_checkpoints._key()
    assert list(key.parent.iterdir()) == []  # neither the key nor its temporary file
    monkeypatch.setattr(os, "fsync", real)
    made = rllib_checkpoints._key()
    assert len(made) == 64 and key.stat().st_mode & 0o777 == 0o600
    rllib_checkpoints._create_key(key)  # another process's late creation keeps the key that is there
    assert rllib_checkpoints._key() == made and len(list(key.parent.iterdir())) == 1


# --- 2. the size of a model file ----------------------------------------------------------------
def _deflated_zeros(mib: int) -> bytes:
    """A raw deflate stream of ``mib`` MiB of zeros, made in milliseconds: one self-contained block
    (ended by a full flush) repeated, then an empty final block."""
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = compressor.compress(bytes(1 << 20)) + compressor.flush(zlib.Z_FULL_FLUSH)
    return block * mib + zlib.compressobj(9, zlib.DEFLATED, -15).flush()


def _bomb(source: Path, target: Path, mib: int, declared: int | None = None, member: str = "policy.pth") -> Path:
    """``source`` with its ``member`` replaced by ``mib`` MiB of zeros, deflated; ``declared``: the
    inflated size its headers state (default: the true one)."""
    members = _members(source)
    members[member] = _deflated_zeros(mib)
    with zipfile.ZipFile(target, "w", zipfile.ZIP_STORED) as archive:
        for name, blob in members.items():
            archive.writestr(name, blob)
    raw = bytearray(target.read_bytes())
    size = (mib << 20) if declared is None else declared
    with zipfile.ZipFile(target) as archive:
        info = archive.getinfo(member)
    local = info.header_offset
    struct.pack_into("<H", raw, local + 8, zipfile.ZIP_DEFLATED)
    struct.pack_into("<I", raw, local + 22, size)
    central = raw.index(b"PK\x01\x02")
    while raw[central + 46 : central + 46 + len(member)] != member.encode():
        central = raw.index(b"PK\x01\x02", central + 4)
    struct.pack_into("<H", raw, central + 10, zipfile.ZIP_DEFLATED)
    struct.pack_into("<I", raw, central + 24, size)
    target.write_bytes(bytes(raw))
    return target


def test_a_real_zip_bomb_is_refused_at_once_by_its_declared_size(model, config_file, tmp_path):
    bomb = _bomb(model, tmp_path / "bomb.zip", 3000)  # 3 MB on disk, 3000 MiB inflated
    assert bomb.stat().st_size < 8 << 20
    peak, start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter()
    result = _eval("--policy", bomb, "--config", config_file, "--out", tmp_path / "b.csv")
    seconds, grown_mb = time.perf_counter() - start, (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak) / 1024
    _refused_in_one_line(result, str(bomb), "'policy.pth'", "3000.0 MiB", "at most 640.0 MiB")
    assert seconds < 5 and grown_mb < 100, (seconds, grown_mb)
    assert not (tmp_path / "b.csv").exists() and not record_path(tmp_path / "b.csv").exists()
    # a header that understates the size: inflating stops where it said, and the member is damaged
    liar = _bomb(model, tmp_path / "liar.zip", 3000, declared=1000)
    start = time.perf_counter()
    result = _eval("--policy", liar, "--config", config_file, "--out", tmp_path / "l.csv")
    _refused_in_one_line(result, str(liar), "policy.pth")
    assert time.perf_counter() - start < 5
    # a data part of 1 GiB
    data = _bomb(model, tmp_path / "data.zip", 1024, member="data")
    result = _eval("--policy", data, "--config", config_file, "--out", tmp_path / "d.csv")
    _refused_in_one_line(result, str(data), "'data' inflates to 1024.0 MiB", "at most 16.0 MiB")


def test_each_member_is_inflated_within_its_budget(model, config_file, tmp_path, monkeypatch):
    monkeypatch.setattr(model_archive, "MAX_DATA_BYTES", 1000)  # the data part is about 10 kB
    result = _eval("--policy", model, "--config", config_file, "--out", tmp_path / "d.csv")
    _refused_in_one_line(result, "'data'", "at most 0.0 MiB")
    monkeypatch.undo()
    monkeypatch.setattr(model_archive, "MAX_MEMBER_BYTES", 4000)
    result = _eval("--policy", model, "--config", config_file, "--out", tmp_path / "p.csv")
    _refused_in_one_line(result, "'policy.pth'", "allowed: at most")
    monkeypatch.undo()
    monkeypatch.setattr(model_archive, "MAX_ARCHIVE_BYTES", 10_000)
    result = _eval("--policy", model, "--config", config_file, "--out", tmp_path / "a.csv")
    _refused_in_one_line(result, "together")


def test_memory_running_out_within_the_budgets_blames_memory_not_trust(model, config_file, tmp_path, monkeypatch):
    def short_of_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(torch, "load", short_of_memory)
    result = _eval("--policy", model, "--config", config_file, "--out", tmp_path / "m.csv")
    _refused_in_one_line(result, str(model), "'policy.pth'", "MiB inflated) does not fit in the memory")


# --- 3. the network, checked before it is built ---------------------------------------------------
def _net_arch(value):
    def change(data):
        data["policy_kwargs"]["net_arch"] = value

    return change


@pytest.mark.parametrize(
    ("arch", "words"),
    [
        ([12000] * 3, ["width 12000", "1 to 4096"]),
        ([-5], ["width -5", "1 to 4096"]),
        ([32] * 17, ["17 layers", "at most 16"]),
        ({"pi": [32], "vf": "x"}, ["net_arch.vf", "list of layer widths"]),
        ([4096] * 6, ["parameters (", "MiB)", "at most 64,000,000"]),
    ],
)
def test_a_network_not_allowed_is_refused_before_it_is_built(model, config_file, tmp_path, arch, words):
    bad = _with_data(model, tmp_path / "arch.zip", _net_arch(arch))
    start = time.perf_counter()
    result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "n.csv")
    _refused_in_one_line(result, str(bad), *words)
    assert time.perf_counter() - start < 10


def test_a_plain_field_of_a_wrong_kind_does_not_blame_trust(model, config_file, tmp_path):
    for field, value, words in (
        ("use_sde", "yes", ["'use_sde' is 'yes'", "true or false"]),
        ("learning_rate", "fast", ["'learning_rate' is 'fast'", "a number or a constant schedule"]),
        ("policy_kwargs", [1], ["'policy_kwargs' is '[1]'", "a mapping"]),
        ("policy_class", None, ["'policy_class' is missing"]),
    ):
        bad = _with_data(model, tmp_path / f"{field}.zip", lambda data: data.__setitem__(field, value))
        result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "f.csv")
        _refused_in_one_line(result, str(bad), *words)


def test_weights_that_are_not_the_declared_network_are_refused_naming_the_tensor(model, config_file, tmp_path):
    def nan(state):
        state["action_net.weight"][0, 0] = float("nan")

    def inf(state):
        state["value_net.bias"][0] = float("inf")

    def shape(state):
        state["action_net.weight"] = torch.zeros(8, 33)

    def dtype(state):
        state["action_net.bias"] = state["action_net.bias"].double()

    def extra(state):
        state["hidden.payload"] = torch.zeros(3)

    def missing(state):
        del state["log_std"]

    for change, words in (
        (nan, ["'action_net.weight'", "1 values that are NaN or infinite"]),
        (inf, ["'value_net.bias'", "NaN or infinite"]),
        (shape, ["'action_net.weight'", "(8, 33)", "(8, 32)"]),
        (dtype, ["'action_net.bias'", "torch.float64", "torch.float32"]),
        (extra, ["'hidden.payload'", "does not have"]),
        (missing, ["lacks tensor 'log_std'"]),
    ):
        bad = _with_state(model, tmp_path / f"{change.__name__}.zip", change)
        result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "w.csv")
        _refused_in_one_line(result, str(bad), *words)


def test_weights_whose_records_are_compressed_inside_torch_format_are_refused_unread(model, config_file, tmp_path):
    """torch.load inflates a deflated record whatever its size (0.4 MB held 400 MB of tensor):
    torch.save writes none, so one is refused before torch.load sees it."""
    members = _members(model)
    inner = zipfile.ZipFile(io.BytesIO(members["policy.pth"]))
    repacked = io.BytesIO()
    with zipfile.ZipFile(repacked, "w") as archive:
        for record in inner.infolist():
            deflated = "/data/" in record.filename
            archive.writestr(record, inner.read(record), zipfile.ZIP_DEFLATED if deflated else zipfile.ZIP_STORED)
    members["policy.pth"] = repacked.getvalue()
    bad = _write(tmp_path / "inner.zip", members)
    result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "i.csv")
    _refused_in_one_line(result, str(bad), "'policy.pth' holds a compressed record", "torch.save writes none")
    members["policy.pth"] = b"\x80\x02" + members["policy.pth"][2:]  # not a zip: the legacy format is refused too
    bad = _write(tmp_path / "legacy.zip", members)
    result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "i.csv")
    _refused_in_one_line(result, str(bad), "not in torch.save's format")


def test_a_data_part_nested_deep_is_one_line(model, config_file, tmp_path):
    for depth in (990, 100):  # beyond what json parses here; within it but beyond the limit
        members = _members(model)
        data = json.loads(members["data"])
        data["policy_kwargs"]["optimizer_kwargs"] = "DEEP"
        members["data"] = json.dumps(data).replace('"DEEP"', "[" * depth + "]" * depth).encode()
        bad = _write(tmp_path / f"deep{depth}.zip", members)
        result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "j.csv")
        _refused_in_one_line(result, str(bad), "nests deeper than 64 levels")


class _Runs:
    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return exec, (f"open({self.marker!r}, 'w').close()",)


def _pickled_weights(model: Path, target: Path, marker: Path) -> Path:
    members = _members(model)
    buffer = io.BytesIO()
    torch.save({"action_net.weight": _Runs(marker)}, buffer)
    members["policy.pth"] = buffer.getvalue()
    return _write(target, members)


def test_weights_that_need_unpickling_run_nothing_and_name_trust(model, config_file, tmp_path):
    marker = tmp_path / "ran"
    bad = _pickled_weights(model, tmp_path / "reduce.zip", marker)
    result = _eval("--policy", bad, "--config", config_file, "--out", tmp_path / "r.csv")
    _refused_in_one_line(result, str(bad), "'policy.pth'", trust=True)  # unpickling would read it: trust is the cause
    assert not marker.exists()


# --- 4. --init-from ---------------------------------------------------------------------------
def test_init_from_a_bad_model_is_one_line_and_leaves_no_run_folder(start_model, config_file, tmp_path):
    marker = tmp_path / "ran"
    source = tmp_path / "init.zip"
    run = tmp_path / "tuned"
    args = ["train", "--init-from", str(source), "--levels", "0", "--difficulty", "0", "--steps", "64"]
    args += ["--envs", "1", "--config", str(config_file), "--run", str(run)]
    for make, words in (
        (lambda: _pickled_weights(start_model, source, marker), ["holds more than plain tensors"]),
        (lambda: _with_state(start_model, source, _nan_in_log_std), ["'log_std'", "NaN"]),
        (lambda: _with_state(start_model, source, _wider), ["'action_net.weight'", "(8, 64)", "(8, 32)"]),
        (lambda: _bomb(start_model, source, 800), ["'policy.pth'", "800.0 MiB"]),
    ):
        make()
        result = CliRunner().invoke(cli, args)
        _refused_in_one_line(result, "--init-from", str(source), *words)
        assert not run.exists() and not marker.exists()
    source.write_bytes(start_model.read_bytes())  # the input fixed, the same command works
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert (run / "final" / "model.zip").is_file()


def _nan_in_log_std(state):
    state["log_std"][0] = float("nan")


def _wider(state):
    state["action_net.weight"] = torch.zeros(8, 64)


# --- 5. fuzzing the loader ------------------------------------------------------------------
@pytest.fixture(scope="module")
def fuzz_env():
    env = AnimalAIEnv(config=load_config(SHORT))
    yield env
    env.close()


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**12), 10**12) | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=6,
)
DATA_KEYS = ["policy_class", "policy_kwargs", "observation_space", "action_space", "learning_rate", "use_sde"]


@st.composite
def mutations(draw):
    kind = draw(st.sampled_from(["flip", "truncate", "field", "net_arch", "tensor"]))
    if kind == "flip":
        return kind, draw(st.sampled_from(["data", "policy.pth"])), draw(st.lists(st.integers(0, 10**6), max_size=4))
    if kind == "truncate":
        return kind, draw(st.sampled_from(["data", "policy.pth"])), draw(st.integers(0, 10**6))
    if kind == "field":
        return kind, draw(st.sampled_from(DATA_KEYS)), draw(JSON_VALUES)
    if kind == "net_arch":
        return kind, "net_arch", draw(JSON_VALUES | st.lists(st.integers(-10, 10**5), max_size=20))
    return kind, draw(st.sampled_from(["action_net.weight", "log_std", "value_net.bias"])), draw(st.floats(width=32))


def _mutate(model: Path, target: Path, mutation) -> Path:
    kind, where, how = mutation
    members = _members(model)
    if kind == "flip":
        blob = bytearray(members[where])
        for position in how:
            blob[position % len(blob)] ^= 0x5A
        members[where] = bytes(blob)
    elif kind == "truncate":
        members[where] = members[where][: how % (len(members[where]) + 1)]
    elif kind in ("field", "net_arch"):
        data = json.loads(members["data"])
        if kind == "field":
            data[where] = how
        else:
            data["policy_kwargs"]["net_arch"] = how
        members["data"] = json.dumps(data).encode()
    else:
        state = torch.load(io.BytesIO(members["policy.pth"]), weights_only=True)
        state[where].view(-1)[0] = how
        buffer = io.BytesIO()
        torch.save(state, buffer)
        members["policy.pth"] = buffer.getvalue()
    return _write(target, members)


@settings(max_examples=30, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutation=mutations())
def test_fuzzed_model_files_load_or_are_refused_cleanly(model, fuzz_env, tmp_path_factory, mutation):
    path = _mutate(model, tmp_path_factory.mktemp("fuzz") / "model.zip", mutation)
    try:
        ModelPolicy(path, fuzz_env)
    except ConfigError as error:
        message = str(error)
        assert "\n" not in message and str(path) in message, message
