"""Bad inputs on the surfaces tests/test_trust.py covers least: damaged model files, hand-made
level specs, and command lines. Each must end in one clear error naming the thing, never a
traceback. (Configs and arena files: tests/test_trust.py, 330 + 120 inputs.)"""

from __future__ import annotations

import io
import json
import math
import zipfile
from dataclasses import replace

import pytest
from click.testing import CliRunner

pytest.importorskip("stable_baselines3", reason="needs the train extra")

from aaai.config import ConfigError, load_config  # noqa: E402
from aaai.env import AnimalAIEnv  # noqa: E402
from aaai.levels import generate  # noqa: E402
from aaai.scoring.policies import ModelPolicy  # noqa: E402
from aaai.spec import AgentPose  # noqa: E402
from aaai_cli.main import cli  # noqa: E402

SHORT = {"episode": {"max_steps": 15}}


# --- model files ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def model_parts(tmp_path_factory):
    from stable_baselines3 import PPO

    env = AnimalAIEnv(config=load_config(SHORT))
    model = PPO(
        "MultiInputPolicy", env, n_steps=64, batch_size=64, seed=0, device="cpu", policy_kwargs={"net_arch": [8, 8]}
    )
    path = tmp_path_factory.mktemp("model") / "model.zip"
    model.save(path)
    env.close()
    with zipfile.ZipFile(path) as archive:
        return path.read_bytes(), {name: archive.read(name) for name in archive.namelist()}


def _zip(parts: dict) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, blob in parts.items():
            archive.writestr(name, blob)
    return buffer.getvalue()


def _with_data(parts: dict, change) -> bytes:
    data = json.loads(parts["data"])
    change(data)
    return _zip({**parts, "data": json.dumps(data).encode()})


def _damaged_models(whole: bytes, parts: dict) -> dict[str, bytes]:
    cases = {
        "empty": b"",
        "text": b"not a model",
        "zeros": bytes(4096),
        "pdf": b"%PDF-1.4\n" + bytes(100),
        "gzip": b"\x1f\x8b\x08" + bytes(64),
        "empty_zip": _zip({}),
    }
    for fraction in (0.01, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99):
        cases[f"cut_at_{fraction}"] = whole[: int(len(whole) * fraction)]
    for name in parts:
        cases[f"without_{name}"] = _zip({k: v for k, v in parts.items() if k != name})
    for name in ("policy.pth", "pytorch_variables.pth", "data"):
        cases[f"garbage_{name}"] = _zip({**parts, name: b"garbage" * 10})
        cases[f"empty_{name}"] = _zip({**parts, name: b""})
    cases["data_an_empty_object"] = _zip({**parts, "data": b"{}"})
    cases["data_null"] = _zip({**parts, "data": b"null"})
    cases["a_zip_in_a_zip"] = _zip({"model.zip": whole})
    cases["policy_a_zip"] = _zip({**parts, "policy.pth": whole})
    cases["data_a_list"] = _zip({**parts, "data": b"[1, 2, 3]"})
    cases["data_a_number"] = _zip({**parts, "data": b"1e400"})
    cases["data_not_utf8"] = _zip({**parts, "data": b"\xff\xfe{}"})
    for field in ("observation_space", "action_space", "policy_class"):
        cases[f"{field}_missing"] = _with_data(parts, lambda d, f=field: d.pop(f, None))
        cases[f"{field}_a_number"] = _with_data(parts, lambda d, f=field: d.__setitem__(f, 7))
        cases[f"{field}_a_string"] = _with_data(parts, lambda d, f=field: d.__setitem__(f, "nothing"))
    cases["policy_kwargs_a_string"] = _with_data(parts, lambda d: d.__setitem__("policy_kwargs", "x"))
    return cases


OPTIONAL = ("pytorch_variables.pth", "policy.optimizer.pth", "_stable_baselines3_version", "system_info.txt")


def test_damaged_model_files_are_refused_naming_the_file(model_parts, tmp_path):
    whole, parts = model_parts
    env = AnimalAIEnv(config=load_config(SHORT))
    cases = _damaged_models(whole, parts)
    try:
        for name, blob in cases.items():
            path = tmp_path / f"{name}.zip"
            path.write_bytes(blob)
            try:
                ModelPolicy(path, env)
            except ConfigError as error:
                assert f"{name}.zip" in str(error), (name, str(error))
            else:
                # Parts scoring does not read (optimizer state, version notes) may be missing or damaged.
                assert name == "policy_kwargs_a_string" or any(name.endswith(part) for part in OPTIONAL), (
                    f"{name} was accepted"
                )
    finally:
        env.close()
    assert len(cases) >= 40


# --- hand-made level specs ---------------------------------------------------------------------
def _bad_specs() -> dict[str, object]:
    """name -> a function building the bad spec (which may refuse it already)."""
    spec = generate(1, 0, 0)
    food = next(obj for obj in spec.objects if obj.is_food)
    cases: dict[str, object] = {}
    for value in (math.nan, math.inf, -math.inf, 1e308, -1e308, 1e6):
        cases[f"agent_x_{value}"] = lambda value=value: replace(spec, agent=AgentPose(value, 0.0, 0.0))
        if not math.isfinite(value):  # (any finite yaw is an angle)
            cases[f"agent_yaw_{value}"] = lambda value=value: replace(spec, agent=AgentPose(0.0, 0.0, value))
        cases[f"food_x_{value}"] = lambda value=value: replace(
            spec, objects=spec.objects + (replace(food, position=(value, 0.0, 0.5)),)
        )
    for size in (
        (0.0, 1.0, 1.0),
        (-1.0, 1.0, 1.0),
        (1.0, 0.0, 1.0),
        (1.0, 1.0, -2.0),
        (math.nan, 1.0, 1.0),
        (math.inf, 1.0, 1.0),
        (1e308, 1e308, 1e308),
    ):
        cases[f"food_size_{size}"] = lambda size=size: replace(spec, objects=spec.objects + (replace(food, size=size),))
    cases["food_twice_in_one_place"] = lambda: replace(spec, objects=spec.objects + (food,))
    cases["food_outside"] = lambda: replace(spec, objects=spec.objects + (replace(food, position=(80.0, 80.0, 0.5)),))
    cases["food_under_the_floor"] = lambda: replace(
        spec, objects=spec.objects + (replace(food, position=(3.0, 3.0, -5.0)),)
    )
    for arena in ((0.0, 50.0), (-10.0, 50.0), (math.nan, 50.0), (math.inf, 50.0), (1e308, 1e308)):
        cases[f"arena_{arena}"] = lambda arena=arena: replace(spec, arena_size=arena)
    for limit in (0.0, 0.1, -1.0, 1000.5, math.nan, math.inf, 1e308):
        cases[f"time_limit_{limit}"] = lambda limit=limit: replace(spec, time_limit=limit)
    for tiles in ((0, 1), (-1, 1)):
        cases[f"tiles_{tiles}"] = lambda tiles=tiles: replace(spec, tiles=tiles)
    cases["hole_outside"] = lambda: replace(spec, tiles=(2, 2), holes=((5, 5),))
    cases["kind_unknown"] = lambda: replace(spec, objects=spec.objects + (replace(food, kind="nothing"),))
    cases["shape_unknown"] = lambda: replace(spec, objects=spec.objects + (replace(food, shape="torus"),))
    cases["not_a_spec"] = lambda: {"agent": [0, 0, 0], "objects": []}
    return cases


def test_bad_hand_made_specs_are_refused_at_reset(tmp_path):
    env = AnimalAIEnv(config=load_config(SHORT))
    cases = _bad_specs()
    accepted = []
    try:
        for name, build in cases.items():
            try:
                env.reset(seed=0, options={"spec": build()})
            except (ConfigError, ValueError) as error:  # refused when built (ObjectSpec) or at reset
                assert str(error).strip(), name
            else:
                accepted.append(name)
    finally:
        env.close()
    assert not accepted, f"accepted: {accepted}"
    assert len(cases) >= 40


# --- command lines ------------------------------------------------------------------------------
BAD_LINES = [
    ["nothing"],
    ["--nothing"],
    ["spec"],
    ["spec", "99"],
    ["spec", "-1"],
    ["spec", "L99"],
    ["spec", "x"],
    ["spec", "1", "-d", "11"],
    ["spec", "1", "-d", "-1"],
    ["spec", "1", "-s", "-1"],
    ["spec", "1", "-s", "x"],
    ["spec", "1", "-s", "99999999999999999999"],
    ["seeds", "--levels", "13"],
    ["seeds", "--levels", "x"],
    ["seeds", "--difficulty", "11"],
    ["seeds", "-k", "0"],
    ["seeds", "-k", "-1"],
    ["seeds", "-k", "x"],
    ["validate", "--levels", "0-x"],
    ["validate", "--seeds", "0"],
    ["validate", "--first-seed", "-1"],
    ["validate", "--arena", "NOFILE"],
    ["run", "--levels", "99"],
    ["run", "--episodes", "0"],
    ["run", "--episodes", "-1"],
    ["run", "--policy", "x"],
    ["run", "--policy", "json:nothing"],
    ["run", "--policy", "NOFILE"],
    ["run", "--policy", "os:system"],
    ["run", "--max-steps", "0"],
    ["run", "--max-steps", "-5"],
    ["run", "--config", "NOFILE"],
    ["run", "--config", "BROKEN"],
    ["run", "--arena", "NOFILE"],
    ["run", "--arena", "BROKEN"],
    ["eval", "-k", "0"],
    ["eval", "--levels", "13"],
    ["eval", "--difficulty", "11"],
    ["eval", "--seeds", "x"],
    ["eval", "--policy", "x"],
    ["eval", "--policy", "json:nothing"],
    ["eval", "--policy", "NOFILE"],
    ["eval", "--backend", "cluster"],
    ["eval", "--workers", "0"],
    ["eval", "--config", "BROKEN"],
    ["eval", "--out", "DIR"],
    ["eval", "--progress-every", "nan"],
    ["eval", "--progress-every", "0"],
    ["train", "--steps", "0"],
    ["train", "--steps", "-1"],
    ["train", "--steps", "x"],
    ["train", "--envs", "0"],
    ["train", "--agent", "x"],
    ["train", "--levels", "13"],
    ["train", "--difficulty", "x"],
    ["train", "--resume", "NOFILE"],
    ["train", "--resume", "DIR"],
    ["train", "--init-from", "NOFILE"],
    ["train", "--config", "BROKEN"],
    ["train", "--camera-resolution", "0"],
    ["train", "--sampler", "x"],
    ["train", "--random", "--sampler", "plr"],
    ["train", "--levels", ""],
    ["seeds", "--levels", "L99"],
    ["train", "--progress-every", "inf"],
    ["train", "--backend", "x"],
    ["train", "--action-mode", "x"],
    ["show", "99"],
    ["show", "x"],
    ["show", "-d", "11"],
    ["show", "--size", "10"],
    ["show", "--fps", "0"],
    ["show", "--steps", "0"],
    ["show", "-o", "out.txt"],
    ["show", "--arena", "NOFILE"],
    ["show", "--arena", "BROKEN"],
    ["show", "--video", "out.gif"],
    ["show", "--policy", "x", "--video", "out.mp4"],
    ["show", "--replay", "NOFILE"],
    ["show", "--replay", "BROKEN", "--video", "out.mp4"],
    ["show", "--config", "BROKEN"],
    ["levels", "--nothing"],
    ["plot"],
    ["plot", "NOFILE"],
    ["import-animalai", "NOFILE"],
    ["import-animalai", "BROKEN"],
    ["play", "--port", "-1"],
    ["play", "--port", "x"],
    ["play", "99"],
]


def test_bad_command_lines_end_in_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a line taken by mistake writes its default outputs here
    broken = tmp_path / "broken.yaml"
    broken.write_text("episode: {max_steps: [\n")
    (tmp_path / "dir").mkdir()
    names = {
        "NOFILE": str(tmp_path / "missing.yaml"),
        "BROKEN": str(broken),
        "DIR": str(tmp_path / "dir"),
        "out.txt": str(tmp_path / "out.txt"),
        "out.gif": str(tmp_path / "out.gif"),
        "out.mp4": str(tmp_path / "out.mp4"),
    }
    assert len({tuple(line) for line in BAD_LINES}) == len(BAD_LINES) >= 80
    for line in BAD_LINES:
        args = [names.get(arg, arg) for arg in line]
        result = CliRunner().invoke(cli, args)
        assert result.exit_code not in (0, None), (line, "accepted", result.output[-500:])
        assert isinstance(result.exception, SystemExit), (line, repr(result.exception), result.output[-500:])
        assert "Traceback" not in result.output and "Error" in result.output, (line, result.output[-500:])
