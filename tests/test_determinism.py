"""The committed baseline scoreboards re-score exactly, on this CPU's code path and on another's.

A learned policy acts in float64 and the actions of learned policies and of the reference are put
on a grid of 2**-20 (aaai.scoring.policies.NUMERICS), so that last-bit differences between CPUs'
code paths (MKL's kernels, vector maths) do not reach the physics (docs/determinism.md)."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aaai.scoring.policies import GRID, NUMERICS, on_grid
from aaai.tools.baselines import COMMITTED, PROVENANCE, differing, rescore

BASELINES = Path(__file__).resolve().parents[1] / "baselines"
# The code path of a CPU without AVX-512, simulated in one process tree (set before any import).
OTHER_CPU = {
    "MKL_CBWR": "AVX2",
    "ATEN_CPU_CAPABILITY": "avx2",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
    "OPENBLAS_CORETYPE": "Haswell",
}


def short_rows(name: str, count: int = 10, folder: Path = BASELINES) -> list[dict]:
    """The shortest committed episode of each level, the ``count`` shortest of those (fast, and
    from different levels)."""
    with open(folder / f"{name}.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    shortest: dict[str, dict] = {}
    for row in rows:
        if row["level"] not in shortest or int(row["steps"]) < int(shortest[row["level"]]["steps"]):
            shortest[row["level"]] = row
    return sorted(shortest.values(), key=lambda row: int(row["steps"]))[:count]


def median_rows(name: str, folder: Path = BASELINES) -> list[dict]:
    """The episode of median length of each level: long enough that the reference's route depends on
    the last bits of its clearance map (the shortest rows passed while that map varied)."""
    with open(folder / f"{name}.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    by_level: dict[str, list[dict]] = {}
    for row in rows:
        by_level.setdefault(row["level"], []).append(row)
    return [sorted(level, key=lambda row: int(row["steps"]))[len(level) // 2] for level in by_level.values()]


def scored_now(name: str) -> bool:
    return json.loads((BASELINES / PROVENANCE).read_text())[name]["numerics"] in (NUMERICS, "none")


LONG = pytest.mark.long  # the other students: each re-scored in make test-long, to keep make test short


@pytest.mark.parametrize(
    "name",
    [
        "reference",
        "student",
        "student_s1",
        "student_food_memory",
        "ppo_gait",
        pytest.param("student_food_memory_s1", marks=LONG),
        pytest.param("student_food_memory_r12", marks=LONG),
        pytest.param("student_food_memory_r12_s1", marks=LONG),
        "student_search_sweep_discrete",  # discrete actions: the likeliest choice of each part
        pytest.param("student_search_sweep_discrete_s1", marks=LONG),
        "student_search_lstm_discrete",  # choices from a memory: the hidden state carried through each row
        pytest.param("student_search_lstm_discrete_s1", marks=LONG),
        pytest.param("student_search_lstm_discrete_r12", marks=LONG),
        pytest.param("student_search_lstm_discrete_r12_s1", marks=LONG),
        pytest.param("student_search_lstm_thorough", marks=LONG),
        pytest.param("student_search_lstm_thorough_s1", marks=LONG),
    ],
)
def test_committed_baseline_rows_rescore_exactly(name):
    if not scored_now(name):
        pytest.skip(f"baselines/{name}.csv was scored before {NUMERICS} (baselines/{PROVENANCE}); re-score it")
    rows = short_rows(name)
    assert len({row["level"] for row in rows}) == 10
    assert differing(rows, rescore(BASELINES, name, rows)) == []


def test_the_camera_students_rows_rescore_exactly():
    """The camera student (a CNN on the head camera's 64 px image, TinyRenderer): 8 rows, the shortest
    of 8 levels, played again give the same rows, image and all."""
    assert scored_now("student_camera"), f"baselines/student_camera.csv was scored before {NUMERICS}"
    rows = short_rows("student_camera", 8)
    assert len({row["level"] for row in rows}) == 8
    assert differing(rows, rescore(BASELINES, "student_camera", rows)) == []


@pytest.mark.parametrize(
    "name",
    [
        "student_search",
        "student_search_lstm",
        "student_search_sweep",
        pytest.param("student_search_sweep_s1", marks=LONG),
    ],
)
def test_the_students_of_the_level_table_rescore_exactly(name):
    """The students of docs/learned-agents.md ("What each level measures"), scored on part of the
    reserved seeds (experiments/students/), their models in baselines/models: 8 rows each, the
    shortest of 8 levels, played again give the same rows (the recurrent one with its memory)."""
    rows = short_rows(name, 8, BASELINES.parent / "experiments" / "students")
    assert len({row["level"] for row in rows}) == 8
    assert differing(rows, rescore(BASELINES, name, rows)) == []


def test_actions_are_put_on_the_grid_and_an_ulp_does_not_move_them():
    action = np.array([0.123456789, -0.987654321, 1.0, -1.0, 0.0])
    gridded = on_grid(action)
    assert gridded.dtype == np.float32 and np.all(np.abs(gridded - action) <= GRID / 2)
    assert np.all(gridded.astype(np.float64) / GRID == np.rint(gridded.astype(np.float64) / GRID))  # exact multiples
    assert np.array_equal(on_grid(np.nextafter(action, 2.0)), gridded)
    assert np.array_equal(on_grid(np.nextafter(action, -2.0)), gridded)


def test_a_learned_policy_acts_in_float64_on_the_grid():
    from dataclasses import replace

    from aaai.config import env_part, load_config
    from aaai.env import AnimalAIEnv
    from aaai.scoring.policies import resolve

    policy = resolve(str(BASELINES / "models" / "student.zip"))
    policy = replace(policy, run_config=load_config(str(BASELINES / "models" / "student.yaml")))
    env = AnimalAIEnv(config=env_part(policy.config(), shaping=0.0))
    try:
        acting = policy.build(env)
        observation, _ = env.reset(seed=1, options={"level": 0, "difficulty": 0})
        action = acting(observation)
    finally:
        env.close()
    assert {p.dtype for p in acting.model.policy.parameters()} == {__import__("torch").float64}
    assert action.dtype == np.float32 and np.array_equal(action, on_grid(action))
    assert policy.numerics == NUMERICS


@pytest.mark.long
def test_the_references_median_episodes_rescore_exactly():
    """The reference's episode of median length on each level, played again, gives the same row: its
    plan reads a clearance map, which once varied with the memory it was written to."""
    rows = median_rows("reference")
    assert len(rows) == 13 and min(int(row["steps"]) for row in rows) > 100
    assert differing(rows, rescore(BASELINES, "reference", rows)) == []


@pytest.mark.long
@pytest.mark.parametrize("name", ["reference", "student", "student_s1", "student_food_memory_s1", "ppo_gait"])
def test_a_sample_rescores_identically_on_another_cpus_code_path(name):
    rows = short_rows(name)
    here = rescore(BASELINES, name, rows)
    script = (
        "import json, sys; from pathlib import Path; from aaai.tools.baselines import rescore; "
        "print(json.dumps(rescore(Path(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3]))))"
    )
    other = subprocess.run(
        [sys.executable, "-c", script, str(BASELINES), name, json.dumps(rows)],
        env={**os.environ, **OTHER_CPU},
        capture_output=True,
        text=True,
        check=True,
    )
    assert differing(here, json.loads(other.stdout)) == []


def test_every_committed_scoreboard_has_its_provenance():
    entries = json.loads((BASELINES / PROVENANCE).read_text())
    assert set(COMMITTED) <= set(entries) and {"numerics", "aaai_version"} <= set(entries["student"])
