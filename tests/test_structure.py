"""The package's shape: no import circle among its modules, and each module opens by naming its job."""

import ast
from pathlib import Path

import pytest

import aaai

ROOT = Path(aaai.__file__).parent
MODULES = {
    ".".join(("aaai", *path.relative_to(ROOT).with_suffix("").parts)).removesuffix(".__init__"): path
    for path in sorted(ROOT.rglob("*.py"))
}


def imported(name: str, path: Path) -> set[str]:
    """The aaai modules a module imports, at the top or inside functions (a lazy import is still a
    dependency), each with the packages Python runs first on the way (aaai.levels for
    aaai.levels.common). The root package, which only registers the ids, is left out."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(
                    package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else [])
                )
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base for alias in node.names]
        else:
            continue
        for target in targets:
            parts = target.split(".")
            for end in range(2, len(parts) + 1):
                if ".".join(parts[:end]) in MODULES:
                    found.add(".".join(parts[:end]))
    found.discard(name)
    return found


def test_no_import_circle():
    graph = {name: imported(name, path) for name, path in MODULES.items() if name != "aaai"}
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycle = path[path.index(nxt) :] + [nxt]
                pytest.fail("import circle: " + " -> ".join(cycle))
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for start in sorted(graph):
        if start not in state:
            visit(start, [start])


def test_lazy_and_submodule_imports_are_dependencies(tmp_path):
    """What would make a circle with the registry (which imports validate) is seen: a lazy import
    inside a function, and a submodule import that runs its package first."""
    lazy = tmp_path / "lazy.py"
    lazy.write_text("def f():\n    from aaai.levels import generate\n")
    assert imported("aaai.sim.geometry", lazy) == {"aaai.levels"}
    deep = tmp_path / "deep.py"
    deep.write_text("from aaai.levels.common import sphere\n")
    assert imported("aaai.sim.geometry", deep) == {"aaai.levels", "aaai.levels.common"}
    assert "aaai.levels.validate" in imported("aaai.levels", MODULES["aaai.levels"])


@pytest.mark.parametrize("name", sorted(MODULES))
def test_each_module_opens_by_naming_its_job(name):
    docstring = ast.get_docstring(ast.parse(MODULES[name].read_text()))
    assert docstring, f"{name} has no module docstring"
    assert len(docstring.splitlines()[0]) <= 110, f"{name}: keep the opening line to one line"


SCORING = (
    "aaai.scoring.evaluation",
    "aaai.scoring.distributed",
    "aaai.scoring.policies",
    "aaai.scoring.model_io",
    "aaai.scoring.runs",
    "aaai.scoring.episodes",
)
TRAINING = (
    "aaai.train.training",
    "aaai.train.learner",
    "aaai.train.rllib_learner",
    "aaai.train.vector",
    "aaai.train.curriculum",
    "aaai.train.student",
    "aaai.train.experiments",
    "aaai.train.competence",
)


def reached(start: str, graph: dict[str, set[str]]) -> dict[str, str]:
    """Every module ``start`` imports, directly or through others: each with the module importing it."""
    via, todo = {start: ""}, [start]
    while todo:
        name = todo.pop()
        for target in sorted(graph.get(name, ())):
            if target not in via:
                via[target] = name
                todo.append(target)
    return via


def chain(name: str, via: dict[str, str]) -> str:
    links = [name]
    while via[links[-1]]:
        links.append(via[links[-1]])
    return " -> ".join(reversed(links))


@pytest.mark.parametrize("module", SCORING)
def test_scoring_imports_nothing_from_training(module):
    """Scoring a policy needs neither a learner nor the curriculum: a scoring module that imports a
    training module (here or through another, lazily or not) is named with the chain that reaches it."""
    assert set(TRAINING) <= set(MODULES) and module in MODULES
    graph = {name: imported(name, path) for name, path in MODULES.items() if name != "aaai"}
    via = reached(module, graph)
    found = [chain(name, via) for name in TRAINING if name in via]
    assert not found, "scoring imports training: " + "; ".join(found)


# The package's map, bottom to top: a module may import its own layer and the layers below, never above.
# A unit is a folder of aaai (aaai.sim) or a module at its top (aaai.config); DEVELOPERS.md, "Layout", reads the same.
LAYERS = (
    ("aaai.errors", "aaai.files", "aaai.safe_yaml", "aaai.jobs", "aaai.numerics"),  # what every module may use
    ("aaai.agent",),  # the body: its URDF table and its handle in a client
    ("aaai.config",),  # the configuration and its rules
    ("aaai.spec",),  # a level as plain data: the spec and its hash, the kinds and moving parts it names
    ("aaai.sim",),  # the simulation that builds and senses a spec: client, world, geometry, senses, gait
    ("aaai.levels",),  # the level registry and generators, the solvability checks, the seed ranges
    ("aaai.task",),  # rewards and the episode's end, arena files, the reference controller
    ("aaai.env", "aaai.registration"),  # the Gymnasium environment and its ids
    ("aaai.scoring",),  # policies, episodes, the scoreboard, run folders, replays
    ("aaai.train",),  # workers, samplers, PPO, DAgger, experiments
    ("aaai.tools",),  # viewer, bench, gait tuning, play, Animal-AI import, baseline table
    ("aaai.study",),  # human studies: the study file, orders, the store, the participant server
)


def layer_of(module: str) -> int:
    top = ".".join(module.split(".")[:2])
    for index, members in enumerate(LAYERS):
        if top in members:
            return index
    raise LookupError(f"{module} is in no layer of LAYERS: put it on the map")


def test_every_module_is_on_the_map():
    for name in MODULES:
        if name != "aaai":
            layer_of(name)


def test_no_import_runs_up_the_map():
    upward = [
        f"{name} (layer {layer_of(name)}) imports {target} (layer {layer_of(target)})"
        for name, path in MODULES.items()
        if name != "aaai"
        for target in sorted(imported(name, path))
        if target != "aaai" and layer_of(target) > layer_of(name)
    ]
    assert not upward, "imports that run up the map:\n" + "\n".join(upward)


def test_an_upward_import_is_caught(tmp_path):
    upward = tmp_path / "sensors.py"
    upward.write_text("def f():\n    from aaai.scoring.evaluation import evaluate\n")
    found = imported("aaai.sim.sensors", upward)
    assert "aaai.scoring.evaluation" in found
    assert any(layer_of(target) > layer_of("aaai.sim.sensors") for target in found)


@pytest.mark.parametrize(
    "lower, upper",
    [("aaai.spec", "aaai.sim"), ("aaai.sim", "aaai.levels"), ("aaai.levels", "aaai.task"), ("aaai.task", "aaai.env")],
)
def test_the_spec_is_under_the_simulation_and_the_levels_under_the_task(lower, upper):
    """The declared order itself: a spec needs no simulator, a level no reward or arena file."""
    assert layer_of(lower) < layer_of(upper)


def unit_of(module: str) -> str:
    """The folder of aaai a module is in (aaai.sim for aaai.sim.world), or the module itself at the top."""
    return ".".join(module.split(".")[:2])


def unit_graph(graph: dict[str, set[str]]) -> dict[str, dict[str, str]]:
    """Which unit imports which: for each (unit, other unit), one import that makes the link."""
    links: dict[str, dict[str, str]] = {}
    for name, targets in sorted(graph.items()):
        for target in sorted(targets, key=lambda t: (-t.count("."), t)):  # the module, before its package
            if target != "aaai" and unit_of(target) != unit_of(name):
                links.setdefault(unit_of(name), {}).setdefault(unit_of(target), f"{name} imports {target}")
    return links


def mutual(links: dict[str, dict[str, str]]) -> list[str]:
    """Every pair of units that import each other, with the import each way."""
    return [
        f"{a} <-> {b}: {links[a][b]}; {links[b][a]}"
        for a in sorted(links)
        for b in sorted(links[a])
        if a < b and a in links.get(b, {})
    ]


def test_no_two_folders_import_each_other():
    """Folders (and top-level modules) depend one way: none imports a unit that imports it back,
    at the top of a file or inside a function."""
    graph = {name: imported(name, path) for name, path in MODULES.items() if name != "aaai"}
    found = mutual(unit_graph(graph))
    assert not found, "units that import each other:\n" + "\n".join(found)


def test_a_pair_of_folders_importing_each_other_is_caught(tmp_path):
    """The check sees a lazy import from a lower folder back up into one that imports it."""
    back = tmp_path / "__init__.py"
    back.write_text("def f():\n    from aaai.task.arena import load_arena\n")
    graph = {name: imported(name, path) for name, path in MODULES.items() if name != "aaai"}
    graph["aaai.levels"] = graph["aaai.levels"] | imported("aaai.levels", back)
    found = mutual(unit_graph(graph))
    assert any(
        line.startswith("aaai.levels <-> aaai.task:") and "aaai.levels imports aaai.task.arena" in line
        for line in found
    )
