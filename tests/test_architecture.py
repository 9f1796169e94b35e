"""The architecture rules of docs/architecture.md, "Layers and packages", on the import graph.

Every ``.py`` file of the repository's packages (``soft_gym``, ``agents``, ``train``, ``eval``) is
parsed with :mod:`ast`; every ``import`` and ``from ... import`` statement counts, wherever it
stands: at module level, inside functions and classes, and under ``if TYPE_CHECKING:`` (a cycle
that only type checkers see is still two modules that cannot be read, moved or tested apart).
Relative imports are resolved against the importing module. An import names the deepest module
of the repository it reaches (``from soft_gym.sensors import fbg`` is an import of
``soft_gym.sensors.fbg``; ``from soft_gym.scenarios import Push`` of ``soft_gym.scenarios``).

The rules: no two modules import each other, directly or around a longer cycle; nothing in
``soft_gym`` imports ``agents``, ``train`` or ``eval``; nothing in ``train`` imports ``eval``
(what both need lives in ``agents`` or ``soft_gym``); only the engine package
(``soft_gym.engines``) imports a physics engine, and everything else uses a simulator through
:class:`soft_gym.simulator.Simulator` and :class:`~soft_gym.simulator.World` alone; the sensors
(``soft_gym.sensors``) import nothing from the estimators (``soft_gym.sensing``); and no file
cites the design document that lived outside the repository (the code cites
docs/architecture.md and the papers instead).
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import pytest

pytestmark = pytest.mark.smoke

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("soft_gym", "agents", "train", "eval")
LOWER_LAYER = "soft_gym"
UPPER_LAYERS = ("agents", "train", "eval")
TRAINING_LAYER, EVALUATION_LAYER = "train", "eval"
"""Peers above ``agents``: training never imports evaluation."""

ENGINE_PACKAGE = "soft_gym.engines"
ENGINE_LIBRARIES = ("pybullet", "pybullet_utils", "pybullet_data", "mujoco")
"""Physics engines' own packages: only :data:`ENGINE_PACKAGE` imports them."""

OLD_CITATIONS = ("DESIGN" + ".md", "papers" + "/README")
"""Citations of the design document outside the repository (spelt apart so that this file does
not cite it)."""

SKIPPED_DIRECTORIES = {".git", ".venv", "__pycache__", ".pytest_cache", "build", "dist", "runs",
                       "results", ".benchmarks", "videos"}
"""Not the repository's own files: version control, the virtualenv and generated output (the
``.gitignore`` entries); ``*.egg-info`` is skipped as well."""


@dataclass(frozen=True)
class Import:
    """One import statement's target as written, and where it stands."""

    importer: str
    name: str
    path: Path
    line: int


def _module_name(path: Path) -> tuple[str, bool]:
    """Dotted module name of ``path`` (relative to the root) and whether it is a package."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    is_package = parts[-1] == "__init__"
    if is_package:
        parts.pop()
    return ".".join(parts), is_package


@lru_cache(maxsize=1)
def _modules() -> dict[str, tuple[Path, bool]]:
    """Every module of the repository's packages: name -> (file, is_package)."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if not SKIPPED_DIRECTORIES.isdisjoint(path.relative_to(ROOT).parts):
                continue
            name, is_package = _module_name(path)
            modules[name] = (path, is_package)
    return modules


def _imports_of(module: str, path: Path, is_package: bool) -> list[Import]:
    """Every import in ``path``, as absolute dotted names (``from a import b`` gives both ``a``
    and ``a.b``, since ``b`` may be a module or a name defined in ``a``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [Import(module, alias.name, path, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".") if is_package else module.split(".")[:-1]
                if node.level - 1 > len(base):
                    raise AssertionError(f"{path}:{node.lineno}: relative import beyond the "
                                         "top-level package")
                base = base[:len(base) - (node.level - 1)]
                parent = ".".join(base + ([node.module] if node.module else []))
            else:
                parent = node.module
            found.append(Import(module, parent, path, node.lineno))
            found += [Import(module, f"{parent}.{alias.name}", path, node.lineno)
                      for alias in node.names if alias.name != "*"]
    return found


@lru_cache(maxsize=1)
def _all_imports() -> tuple[Import, ...]:
    return tuple(found for module, (path, is_package) in _modules().items()
                 for found in _imports_of(module, path, is_package))


def _resolve(name: str) -> str | None:
    """The deepest repository module ``name`` reaches, or None for other packages."""
    modules = _modules()
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


@lru_cache(maxsize=1)
def _graph() -> dict[str, dict[str, Import]]:
    """importer -> {imported module -> the first import statement that makes the edge}."""
    graph: dict[str, dict[str, Import]] = {module: {} for module in _modules()}
    for found in _all_imports():
        target = _resolve(found.name)
        if target is not None and target != found.importer:
            graph[found.importer].setdefault(target, found)
    return graph


def _strongly_connected(graph: dict[str, dict[str, Import]]) -> list[list[str]]:
    """Tarjan's strongly connected components with more than one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in graph[node]:
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return components


def _cycle_through(start: str, members: set[str], graph: dict[str, dict[str, Import]]) -> list[str]:
    """A shortest import cycle from ``start`` back to it inside one component."""
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for successor in sorted(graph[node]):
                if successor not in members or successor in previous:
                    continue
                previous[successor] = node
                if successor == start:
                    path = [start]
                    while path[-1] != start or len(path) == 1:
                        path.append(previous[path[-1]])
                    return path[::-1]
                following.append(successor)
        frontier = following
    raise AssertionError(f"no cycle through {start}")  # pragma: no cover - a component has one


def _describe(cycle: list[str], graph: dict[str, dict[str, Import]]) -> str:
    steps = []
    for importer, imported in zip(cycle, cycle[1:]):
        where = graph[importer][imported]
        steps.append(f"{where.path.relative_to(ROOT)}:{where.line} imports {imported}")
    return " -> ".join(cycle) + " (" + "; ".join(steps) + ")"


def test_the_import_graph_covers_every_package():
    """The parser finds the packages' modules and their imports (else the rules check nothing)."""
    modules = _modules()
    for package in PACKAGES:
        assert package in modules, f"package {package} has no __init__.py under {ROOT}"
    graph = _graph()
    assert "soft_gym.engines" in graph["soft_gym.envs.soft_arm_env"]
    assert "soft_gym.robots.spec" in graph["soft_gym.engines.pybullet.simulator"]
    assert "soft_gym.engines" in graph["soft_gym.procedures.workspace"]
    assert "soft_gym.kinematics" in graph["agents.controllers.cc_model"]


def test_the_cycle_finder_finds_and_describes_a_cycle():
    """On a made-up graph: a -> b -> c -> a is one cycle, d -> a is not part of it."""
    here = Path(__file__).resolve()
    edges = {"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}
    graph = {node: {target: Import(node, target, here, 1) for target in targets}
             for node, targets in edges.items()}
    assert _strongly_connected(graph) == [["a", "b", "c"]]
    assert _cycle_through("a", {"a", "b", "c"}, graph) == ["a", "b", "c", "a"]
    assert _describe(["a", "b", "a"], {"a": {"b": graph["a"]["b"]}, "b": {"a": graph["c"]["a"]}}
                     ).startswith("a -> b -> a (tests/test_architecture.py:1 imports b;")


def test_no_import_cycles_between_modules():
    graph = _graph()
    cycles = [_describe(_cycle_through(component[0], set(component), graph), graph)
              for component in _strongly_connected(graph)]
    assert not cycles, ("modules importing each other (move the shared part into a module both "
                        "import, or pass the object in):\n" + "\n".join(cycles))


def test_soft_gym_imports_no_agents_train_or_eval():
    wrong = [f"{found.path.relative_to(ROOT)}:{found.line} imports {found.name}"
             for found in _all_imports()
             if found.importer.split(".")[0] == LOWER_LAYER
             and found.name.split(".")[0] in UPPER_LAYERS]
    assert not wrong, ("soft_gym is the bottom layer and must not import agents, train or eval "
                       "(docs/architecture.md, \"Layers and packages\"):\n" + "\n".join(wrong))


SENSORS_PACKAGE = "soft_gym.sensors"
ESTIMATION_PACKAGE = "soft_gym.sensing"


def test_sensors_never_import_the_estimators():
    wrong = [f"{found.path.relative_to(ROOT)}:{found.line} imports {found.name}"
             for found in _all_imports()
             if found.importer.startswith(SENSORS_PACKAGE)
             and (_resolve(found.name) or "").startswith(ESTIMATION_PACKAGE)]
    assert not wrong, ("the sensors are the layer below the estimators: move what both need "
                       "(as the Measurement in soft_gym/sensors/measurement.py) into "
                       "soft_gym/sensors/ (docs/architecture.md, \"Layers and packages\"):\n"
                       + "\n".join(wrong))


def test_train_imports_no_eval():
    wrong = [f"{found.path.relative_to(ROOT)}:{found.line} imports {found.name}"
             for found in _all_imports()
             if found.importer.split(".")[0] == TRAINING_LAYER
             and found.name.split(".")[0] == EVALUATION_LAYER]
    assert not wrong, ("train must not import eval: move what both need into agents (as "
                       "agents/rollout.py) or soft_gym (docs/architecture.md, \"Layers and "
                       "packages\"):\n" + "\n".join(wrong))


ESTIMATION_AND_TASKS = ("soft_gym.sensing", "soft_gym.tasks")
"""Packages that never drive a simulator: an estimator has its readings, a task its targets."""


def test_sensing_and_tasks_never_import_a_simulator():
    wrong = [f"{found.path.relative_to(ROOT)}:{found.line} imports {found.name}"
             for found in _all_imports()
             if found.importer.startswith(ESTIMATION_AND_TASKS)
             and (_resolve(found.name) or "").startswith((ENGINE_PACKAGE, "soft_gym.simulator", "soft_gym.procedures",
                                                          "soft_gym.envs"))]
    assert not wrong, ("estimators and tasks never hold a simulator: move what drives one into "
                       "soft_gym/procedures/ and hand its result down:\n" + "\n".join(wrong))


SIMULATOR_MODULES = (ENGINE_PACKAGE, "soft_gym.simulator", "soft_gym.procedures", "soft_gym.envs")
"""What drives a simulator: an estimator imports none of them, directly or through another
module."""


def _reached_from(start: str, graph: dict[str, dict[str, Import]]) -> dict[str, list[str]]:
    """Every repository module ``start`` imports, directly or not: module -> the import chain."""
    chains = {start: [start]}
    frontier = [start]
    while frontier:
        module = frontier.pop()
        for target in graph.get(module, {}):
            if target not in chains:
                chains[target] = chains[module] + [target]
                frontier.append(target)
    return chains


def _paper_estimator_modules() -> dict[str, set[str]]:
    """Each registered paper's feedback-source modules, by paper key."""
    from soft_gym.papers import PAPERS

    return {key: {source.__module__ for source in paper.feedback_sources}
            for key, paper in PAPERS.items()}


@pytest.mark.parametrize("paper", sorted(_paper_estimator_modules()))
def test_a_papers_estimators_never_reach_a_simulator(paper):
    """Checked per paper folder: from the paper's feedback sources, no chain of imports reaches
    what drives a simulator; its calibration procedures (which may) are handed in by the paper's
    registration instead."""
    graph = _graph()
    wrong = []
    for start in sorted(_paper_estimator_modules()[paper]):
        for module, chain in _reached_from(start, graph).items():
            if module.startswith(SIMULATOR_MODULES):
                wrong.append(" -> ".join(chain))
    assert not wrong, (f"{paper}'s estimators reach a simulator (move what drives one into the "
                       f"paper's calibration procedure):\n" + "\n".join(wrong))


def test_every_paper_folder_is_a_registered_paper_with_its_estimators_inside():
    from soft_gym.papers import PAPERS

    folders = sorted(path.name for path in (ROOT / "soft_gym" / "papers").iterdir()
                     if (path / "__init__.py").exists())
    assert folders == sorted(PAPERS)
    for key, modules in _paper_estimator_modules().items():
        assert all(module.startswith(f"soft_gym.papers.{key}.") for module in modules), modules
        assert PAPERS[key].evaluation in (None, f"eval.papers.{key}")


def test_only_the_engine_package_imports_a_physics_engine():
    wrong = [f"{found.path.relative_to(ROOT)}:{found.line} imports {found.name}"
             for found in _all_imports()
             if found.name.split(".")[0] in ENGINE_LIBRARIES
             and not found.importer.startswith(ENGINE_PACKAGE)]
    assert not wrong, ("only soft_gym/engines/ may call a physics engine; use the simulator "
                       "interface (docs/architecture.md, \"The simulator interface\"):\n"
                       + "\n".join(wrong))


def _is_simulator(node: ast.expr) -> bool:
    """Whether an expression names a simulator: ``sim``, ``simulator`` or ``<anything>.sim``."""
    return ((isinstance(node, ast.Name) and node.id in ("sim", "simulator"))
            or (isinstance(node, ast.Attribute) and node.attr == "sim"))


def _interface_breaches(tree: ast.AST) -> list[tuple[int, str]]:
    """``(line, attribute)`` of every read of a simulator attribute that the interface does not
    name (``sim.client``), and of every world attribute outside :class:`World`."""
    from soft_gym.simulator import SIMULATOR_NAMES, WORLD_NAMES

    breaches = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        if _is_simulator(node.value) and node.attr not in SIMULATOR_NAMES:
            breaches.append((node.lineno, f"sim.{node.attr}"))
        elif (isinstance(node.value, ast.Attribute) and node.value.attr == "world"
              and _is_simulator(node.value.value) and node.attr not in WORLD_NAMES):
            breaches.append((node.lineno, f"sim.world.{node.attr}"))
    return sorted(breaches)


def test_the_interface_check_finds_a_breach():
    tree = ast.parse("sim.client.getNumBodies()\nenv.sim.arm.body_id\nsim.tip_pose()\n"
                     "self.sim.world.render_camera(k, r, p, l)\nsim.world.client\n")
    assert _interface_breaches(tree) == [(1, "sim.client"), (2, "sim.arm"),
                                         (5, "sim.world.client")]


def test_outside_the_engines_a_simulator_is_used_through_its_interface_alone():
    breaches = [f"{path.relative_to(ROOT)}:{line} reads {attribute}"
                for module, (path, _) in _modules().items()
                if not module.startswith(ENGINE_PACKAGE)
                for line, attribute in _interface_breaches(
                    ast.parse(path.read_text(encoding="utf-8")))]
    assert not breaches, ("use soft_gym.simulator.Simulator's and World's methods (or add one "
                          "to the interface and every engine):\n" + "\n".join(breaches))


def test_every_engine_implements_the_interface():
    from soft_gym.engines import ENGINES
    from soft_gym.robots import get_preset
    from soft_gym.simulator import SIMULATOR_NAMES, WORLD_NAMES, Simulator, World

    for name in ENGINES:
        sim = ENGINES[name](get_preset("wang2023"))
        try:
            assert isinstance(sim, Simulator) and isinstance(sim.world, World), name
            missing = sorted(attribute for attribute in SIMULATOR_NAMES
                             if not hasattr(sim, attribute))
            missing += sorted(f"world.{attribute}" for attribute in WORLD_NAMES
                              if not hasattr(sim.world, attribute))
            assert not missing, f"engine {name!r} lacks {missing}"
        finally:
            sim.close()


def _repository_files():
    for path in sorted(ROOT.rglob("*")):
        parts = path.relative_to(ROOT).parts
        if not SKIPPED_DIRECTORIES.isdisjoint(parts) or any(
                part.endswith(".egg-info") for part in parts):
            continue
        if path.is_file() and not path.is_symlink():
            yield path


def test_no_file_cites_the_design_document_outside_the_repository():
    """Code, docs and README cite docs/architecture.md (section name) or a paper (key and
    equation), never a file users do not have."""
    citing = []
    patterns = [citation.encode() for citation in OLD_CITATIONS]
    for path in _repository_files():
        data = path.read_bytes()
        if not any(pattern in data for pattern in patterns):
            continue
        for number, line in enumerate(data.splitlines(), start=1):
            if any(pattern in line for pattern in patterns):
                citing.append(f"{path.relative_to(ROOT)}:{number}: "
                              f"{line.decode('utf-8', 'replace').strip()}")
    assert not citing, ("cite docs/architecture.md or the paper instead of the old design "
                        "document:\n" + "\n".join(citing))


def test_every_cited_section_of_the_architecture_document_exists():
    """A citation ``docs/architecture.md, "<section>"`` names a heading of that document
    (``<...>`` stands for a placeholder)."""
    document = ROOT / "docs" / "architecture.md"
    headings = {re.sub(r"^\d+\.\s*", "", line.lstrip("#").strip())
                for line in document.read_text(encoding="utf-8").splitlines()
                if line.startswith("#")}
    citation = re.compile(r'docs/architecture\.md,?\s*\(?"([^"]{1,80})"')
    unknown = []
    for path in _repository_files():
        if path.suffix not in (".py", ".md"):
            continue
        for match in citation.finditer(path.read_text(encoding="utf-8")):
            section = " ".join(match.group(1).split())  # a citation may wrap in a docstring
            if section not in headings and not section.startswith("<"):
                unknown.append(f"{path.relative_to(ROOT)}: \"{section}\"")
    assert not unknown, (f"sections cited but not headings of {document.relative_to(ROOT)}:\n"
                         + "\n".join(unknown))
