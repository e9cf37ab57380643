"""Training gives the same weights on any CPU: the aaai command runs MKL's compatible code path
(aaai.numerics; docs/determinism.md, "Training on another CPU").

MKL picks its float32 kernels by the CPU, and a student's fit turns their last bits into other
weights. The long tests train a small DAgger student (two rounds of six episodes) and compare its
weights with the bytes pinned here for the CPU's maker (trained on 2026-12-01 on an AMD EPYC and on
2026-12-03 on an Intel Xeon: the compatible path gives other bytes on the two); and once more with the
code paths of a CPU without AVX-512 simulated for torch, numpy, OpenBLAS and MKL's instruction set
(MKL's own choice of path is what this feature fixes)."""

import hashlib
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import yaml
from conftest import AAAI
from test_determinism import OTHER_CPU as SIMULATED

ROOT = Path(__file__).resolve().parents[1]
# policy.pth of the small run's final model, trained by `aaai train` with MKL_CBWR=COMPATIBLE, by the
# CPU's maker (/proc/cpuinfo's vendor_id): MKL's compatible path gives the same bytes on every CPU of
# one maker measured so far, but not across makers (docs/determinism.md, "Training on another CPU"). A
# change to the env, the teacher or DAgger changes them: train the run again on each (test_..._pinned_bytes
# prints the new digest) and pin that, after checking that MKL_CBWR=AVX2 still gives other bytes.
PINNED = {
    "AuthenticAMD": "a47ff6eed5d81eed168dd265548190fb2dc458754f3bf7ec5ffba1b7f7a6b095",  # AMD EPYC; 2026-12-01
    "GenuineIntel": "71ed668132ebd165eed7dda6c5fafe242c561dd25126d6c1fe7078fc4635c9e8",  # Intel Xeon; 2026-12-03
}
# test_determinism's CPU without AVX-512, but for MKL_CBWR (the setting under test): MKL limited to AVX2
OTHER_CPU = {**{key: value for key, value in SIMULATED.items() if key != "MKL_CBWR"}, "MKL_ENABLE_INSTRUCTIONS": "AVX2"}


def cpu_maker() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("vendor_id"):
            return line.split(":", 1)[1].strip()
    return "unknown"


def pinned(digest: str) -> str:
    """The pinned bytes for this CPU's maker. A maker not measured yet has nothing to compare with: the
    test is skipped, saying so and naming the digest to pin (the simulated-paths test still runs)."""
    maker = cpu_maker()
    if maker not in PINNED:
        pytest.skip(f"no weights pinned yet for CPUs made by {maker!r} (PINNED): this one trains to {digest}; pin it")
    return PINNED[maker]


def environment(**extra: str) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items() if key != "MKL_CBWR"}
    return {**env, **extra}


def small_student(tmp_path: Path, env: dict[str, str]) -> tuple[str, dict]:
    """Trains the small student in a fresh ``aaai`` process; its final weights' SHA-256 and versions.json."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    config = yaml.safe_load((ROOT / "configs" / "student_food_memory.yaml").read_text())
    config["train"].update(dagger_iterations=2, dagger_episodes=6, dagger_episode_cap=80, processes=1)
    path, run = tmp_path / "small.yaml", tmp_path / "run"
    path.write_text(yaml.safe_dump(config))
    command = [*AAAI, "train", "--config", str(path), "--run", str(run)]
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    with zipfile.ZipFile(run / "final" / "model.zip") as archive:
        digest = hashlib.sha256(archive.read("policy.pth")).hexdigest()
    return digest, json.loads((run / "versions.json").read_text())


def test_the_aaai_command_asks_mkl_for_its_compatible_path_and_keeps_a_users_own():
    probe = "import aaai_cli, os; print(os.environ['MKL_CBWR'])"
    for env, expected in ((environment(), "COMPATIBLE"), (environment(MKL_CBWR="AVX2"), "AVX2")):
        done = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True)
        assert done.stdout.strip() == expected, done.stderr


@pytest.mark.long
def test_a_small_student_trains_to_the_pinned_bytes(tmp_path):
    digest, versions = small_student(tmp_path, environment())
    assert versions["MKL_CBWR"] == "COMPATIBLE"
    assert digest == pinned(digest), f"the small student's weights are {digest}, not the pinned ones (see PINNED)"


@pytest.mark.long
def test_a_small_student_trains_to_the_same_bytes_on_another_cpus_code_paths(tmp_path):
    digest, _ = small_student(tmp_path / "simulated", environment(**OTHER_CPU))
    # against the bytes pinned for this CPU's maker, or (a maker not measured yet) this CPU's own run
    expected = PINNED.get(cpu_maker()) or small_student(tmp_path / "native", environment())[0]
    assert digest == expected


@pytest.mark.long
def test_mkl_left_to_choose_records_it(tmp_path):
    """MKL_CBWR= (empty): MKL's own choice, recorded as unset in the run folder."""
    _, versions = small_student(tmp_path, environment(MKL_CBWR=""))
    assert versions["MKL_CBWR"] == "unset"
