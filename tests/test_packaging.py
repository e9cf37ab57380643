"""The package as `pip install aaai` (not editable) gives it: the wheel built from this checkout
holds every module and data file the environment, the CLI and `aaai play` need, run here from the
unpacked wheel with this checkout out of reach."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("setup.cfg", "pyproject.toml", "README.md", "aaai", "cli", "configs")

# run from the unpacked wheel: the editable install's finder and this checkout are taken off the path
PROBE = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in type(f).__module__.lower()]
    checkout = {Path(ROOT), Path(ROOT) / "cli", Path(ROOT) / "configs"}
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() not in checkout]
    import importlib, pkgutil
    from importlib import resources

    import aaai, aaai_cli, aaai_configs
    for package in (aaai, aaai_cli, aaai_configs):
        assert Path(package.__file__).is_relative_to(SITE), package.__file__
    for module in pkgutil.walk_packages(aaai.__path__, "aaai."):
        importlib.import_module(module.name)
    assert (resources.files("aaai.tools.play") / "static" / "index.html").is_file(), "aaai play's page"

    from aaai.env import AnimalAIEnv
    from aaai.levels import all_levels
    env = AnimalAIEnv()
    for level in sorted(all_levels()):
        env.reset(seed=0, options={"level": level, "difficulty": 10})
        env.step(env.action_space.sample())
    env.close()

    from click.testing import CliRunner
    from aaai_cli.main import cli
    result = CliRunner().invoke(cli, ["run", "--policy", "reference", "--levels", "0", "--difficulty", "0"])
    assert result.exit_code == 0 and "ate green" in result.output, result.output
    print("ok")
    """
)


def test_the_built_wheel_runs_the_environment_and_the_cli_without_the_checkout(tmp_path):
    # built from a copy of what the build reads, so that no build/ or egg-info left in the checkout
    # by an earlier build can add files the package lists do not name
    source = tmp_path / "source"
    source.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy(ROOT / name, source / name)
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation", "-q"]
        + ["-w", str(wheels)],
        check=True,
        capture_output=True,
        cwd=tmp_path,
    )
    (wheel,) = wheels.glob("aaai-*.whl")
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        archive.extractall(site)
        held = set(archive.namelist())
    # every module and data file of the three packages: aaai/, cli/ as aaai_cli, configs/ as aaai_configs
    # (the files git tracks there: an untracked editor backup is not the package's)
    tracked = subprocess.run(["git", "ls-files", "aaai", "cli", "configs"], cwd=ROOT, capture_output=True, text=True)
    assert tracked.returncode == 0, tracked.stderr
    packages = {"aaai": "aaai", "cli": "aaai_cli", "configs": "aaai_configs"}
    wanted = {
        f"{packages[folder]}/{rest}" for folder, _, rest in (line.partition("/") for line in tracked.stdout.split())
    }
    assert not wanted - held, f"files missing from the wheel: {sorted(wanted - held)}"
    code = f"ROOT = {str(ROOT)!r}\nSITE = {str(site)!r}\n" + PROBE
    run = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"},
        timeout=300,
    )
    assert run.returncode == 0 and run.stdout.strip().endswith("ok"), run.stdout[-2000:] + run.stderr[-4000:]
