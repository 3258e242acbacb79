"""The package's shape: every stage imports only from the stages before it, and docs link to real files."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sumo_rail"
STAGES = ("", "sim", "drivers", "runners", "recordings", "evaluation", "learning", "report")
"""The data flow, first to last; "" is the top level (config, seeding, datasets)."""


def stage_of(module: str) -> str:
    """The stage of a dotted module name inside sumo_rail ("" for the top level)."""
    parts = module.split(".")
    return parts[1] if len(parts) >= 2 and parts[1] in STAGES else ""


def module_name(path: Path, root: Path) -> str:
    return ".".join(path.relative_to(root).with_suffix("").parts)


def imported_modules(path: Path, root: Path) -> list[tuple[int, str]]:
    """(line, module) for every sumo_rail import in a file, typing-only and function-local ones included."""
    module = module_name(path, root)
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.rsplit(".", node.level)[0]
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module or ""
            names = [f"{name}.{alias.name}" for alias in node.names]
            found += [(node.lineno, target) for target in [name, *names] if target.startswith("sumo_rail.")]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names if alias.name.startswith("sumo_rail.")]
    return found


def backward_imports(path: Path, root: Path = ROOT) -> list[str]:
    """'file:line imports module' for each import of a later stage than the file's own."""
    own = STAGES.index(stage_of(module_name(path, root)))
    return [f"{path.relative_to(root)}:{line} imports {target}" for line, target in imported_modules(path, root)
            if STAGES.index(stage_of(target)) > own]


def test_every_module_belongs_to_a_stage():
    """A stage is a folder of sumo_rail; a folder inside it (learning/rail, learning/sb3) belongs to that stage."""
    folders = {path.relative_to(PACKAGE).parts[0] for path in PACKAGE.rglob("*.py") if path.parent != PACKAGE}
    assert folders == set(STAGES) - {""}
    packages = {path.parent for path in PACKAGE.rglob("*.py")}
    assert sorted(str(folder.relative_to(ROOT)) for folder in packages if not (folder / "__init__.py").is_file()) == []
    assert sorted(path.name for path in PACKAGE.glob("*.py")) == ["__init__.py", "action_config.py", "bounds.py",
                                                                     "config.py", "datasets.py", "seeding.py",
                                                                     "setting_tables.py"]


def test_no_module_imports_a_later_stage():
    modules = sorted(set(PACKAGE.rglob("*.py")) - {PACKAGE / "__init__.py"})  # the package re-exports HighwayEnv
    offenders = [line for path in modules for line in backward_imports(path)]
    assert offenders == []


MAX_MODULE_LINES = 400
"""The project's limit on a module's length (docs/design.md: modules under ~400 lines, one responsibility each)."""


def long_modules(root: Path) -> list[str]:
    """'path: N lines' for each Python module under `root` longer than MAX_MODULE_LINES."""
    lengths = {path: len(path.read_text().splitlines()) for path in sorted(root.rglob("*.py"))}
    return [f"{path.relative_to(root.parent)}: {lines} lines" for path, lines in lengths.items()
            if lines > MAX_MODULE_LINES]


def test_no_module_is_over_400_lines():
    assert long_modules(PACKAGE) + long_modules(ROOT / "cli") == []


def test_the_length_check_finds_a_long_module(tmp_path):
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    (tmp_path / "pkg" / "short.py").write_text("x = 1\n" * MAX_MODULE_LINES)
    (tmp_path / "pkg" / "sub" / "long.py").write_text("x = 1\n" * (MAX_MODULE_LINES + 1))
    assert long_modules(tmp_path / "pkg") == [f"pkg/sub/long.py: {MAX_MODULE_LINES + 1} lines"]


def test_the_check_catches_backward_imports_absolute_relative_and_local(tmp_path):
    module = tmp_path / "sumo_rail" / "sim" / "bad.py"
    module.parent.mkdir(parents=True)
    module.write_text("from sumo_rail.learning.rail.iteration import run_iteration\nfrom . import lidar\n"
                      "from ..report import plots\ndef f():\n    import sumo_rail.runners.rollout\n")
    assert backward_imports(module, tmp_path) == [
        "sumo_rail/sim/bad.py:1 imports sumo_rail.learning.rail.iteration",
        "sumo_rail/sim/bad.py:1 imports sumo_rail.learning.rail.iteration.run_iteration",
        "sumo_rail/sim/bad.py:3 imports sumo_rail.report",
        "sumo_rail/sim/bad.py:3 imports sumo_rail.report.plots",
        "sumo_rail/sim/bad.py:5 imports sumo_rail.runners.rollout",
    ]


def test_each_stage_says_what_it_does_and_may_import():
    for stage in STAGES[1:]:
        docstring = ast.get_docstring(ast.parse((PACKAGE / stage / "__init__.py").read_text())) or ""
        assert "May import" in docstring, stage


def missing_link_targets(documents: list[Path]) -> list[str]:
    """'document -> target' for each relative Markdown link whose target does not exist."""
    return [f"{document.name} -> {target}" for document in documents
            for target in re.findall(r"\]\(([^)#\s]+)", document.read_text())
            if "://" not in target and not (document.parent / target).exists()]


def test_relative_links_resolve_to_files_in_the_repository():
    documents = [ROOT / "README.md", ROOT / "demos" / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    assert missing_link_targets(documents) == []


def test_the_link_check_finds_a_dangling_link(tmp_path):
    (tmp_path / "plot.png").write_bytes(b"")
    document = tmp_path / "doc.md"
    document.write_text("![a](plot.png) [b](gone/report.md#top) [c](https://example.org/x) [d](plot.png#x)")
    assert missing_link_targets([document]) == ["doc.md -> gone/report.md"]


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module -> the package's modules it imports anywhere in its file (function-level and typing-only included)."""
    files = {module_name(path, root): path for path in (root / "sumo_rail").rglob("*.py")}
    modules = {name.removesuffix(".__init__"): path for name, path in files.items()}
    return {module: {target for _, target in imported_modules(path, root) if target in modules and target != module}
            for module, path in modules.items()}


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (each an import circle), by Tarjan's algorithm."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for target in sorted(graph.get(module, ())):
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:
            group = []
            while True:
                member = stack.pop()
                group.append(member)
                if member == module:
                    break
            if len(group) > 1:
                cycles.append(sorted(group))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return cycles


def test_no_import_circle_anywhere_in_the_package():
    assert import_cycles(import_graph()) == []


def test_the_circle_check_finds_a_circle_through_a_function_level_import(tmp_path):
    package = tmp_path / "sumo_rail" / "sim"
    package.mkdir(parents=True)
    (tmp_path / "sumo_rail" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from sumo_rail.sim.b import thing\n")
    (package / "b.py").write_text("def thing():\n    from sumo_rail.sim import a\n")
    (package / "c.py").write_text("from sumo_rail.sim import a\n")
    assert import_cycles(import_graph(tmp_path)) == [["sumo_rail.sim.a", "sumo_rail.sim.b"]]


SUMO_API = ("libsumo", "traci", "sumolib")
"""SUMO's Python APIs: spoken to only from sumo_rail/sim/ (docs/design.md, "Where to find it": the SUMO boundary)."""
SUMO_LOADERS = ("load_api", "load_constants", "decision_calls")
"""What `sumo_rail.sim.sumo_api` hands out of SUMO's API itself (its constants and errors may be imported anywhere)."""
BOUNDARY_EXEMPT: dict[str, str] = {}
"""Files outside sim/ that still cross the boundary, with why; each that exists must still cross it (the list only
shrinks)."""


def boundary_scope(root: Path = ROOT) -> list[Path]:
    """The modules the SUMO boundary holds for: the package outside sim/, the CLI and the experiments (not the tests,
    which check SUMO's own state, nor the benchmarks, which time raw SUMO as their baseline)."""
    package = [path for path in (root / "sumo_rail").rglob("*.py") if "sim" not in path.relative_to(root).parts[1:2]]
    return sorted([*package, *(root / "cli").rglob("*.py"), *(root / "experiments").rglob("*.py")])


def sim_private_names(root: Path = ROOT) -> set[str]:
    """Every private name sumo_rail/sim/ defines: `_x` functions, classes, methods, module and class attributes and
    `self._x` attributes of its modules (a dunder or `_` alone is not one)."""
    names = set()
    for path in (root / "sumo_rail" / "sim").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                names.add(node.attr)
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                names.add(node.id)
    return {name for name in names if name.startswith("_") and not name.startswith("__") and name != "_"}


def boundary_breaches(path: Path, private: set[str], root: Path = ROOT) -> list[str]:
    """'file:line what' for each crossing of the SUMO boundary in a module outside sim/: an import of SUMO's API
    (`SUMO_API`, or `SUMO_LOADERS` from sim), an import of a private name of sim, a private name of sim (`private`)
    read or written on any object but a module imported from outside the package, and, in a class derived from a
    class of sim, on `self`, `cls` or `super()` too, or overridden there."""
    tree = ast.parse(path.read_text())
    where = path.relative_to(root)
    sim_names, outside_modules, found = set(), set(), []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in SUMO_API:
                    found.append(f"{where}:{node.lineno} imports {alias.name}")
                if not alias.name.startswith("sumo_rail"):
                    outside_modules.add(alias.asname or alias.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom) and node.module:
            if node.module.split(".")[0] in SUMO_API:
                found.append(f"{where}:{node.lineno} imports {node.module}")
            elif node.module.startswith("sumo_rail.sim"):
                sim_names.update(alias.asname or alias.name for alias in node.names)
                found += [f"{where}:{node.lineno} imports {node.module}.{alias.name}" for alias in node.names
                          if alias.name in SUMO_LOADERS or alias.name.startswith("_")]
    derived = [node for node in ast.walk(tree) if isinstance(node, ast.ClassDef)
               and any(isinstance(base, ast.Name) and base.id in sim_names for base in node.bases)]
    inside_derived = {id(node) for cls in derived for node in ast.walk(cls)}
    found += [f"{where}:{node.lineno} overrides {node.name}" for cls in derived for node in cls.body
              if isinstance(node, ast.FunctionDef) and node.name in private]
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and node.attr in private):
            continue
        receiver = node.value
        own = (isinstance(receiver, ast.Name) and receiver.id in ("self", "cls")) or (
            isinstance(receiver, ast.Call) and isinstance(receiver.func, ast.Name) and receiver.func.id == "super")
        if (isinstance(receiver, ast.Name) and receiver.id in outside_modules) or (own and id(node) not in
                                                                                  inside_derived):
            continue
        found.append(f"{where}:{node.lineno} touches {ast.unparse(node)}")
    return sorted(found, key=lambda line: int(line.split(":")[1].split()[0]))


def test_sumo_is_spoken_to_only_from_sim():
    """No module outside sumo_rail/sim/ imports SUMO's API or touches a private member of sim (docs/design.md, "The
    SUMO boundary"), but the exempt ones, which still do."""
    private = sim_private_names()
    breaches = {path: boundary_breaches(path, private) for path in boundary_scope()}
    exempt = {str(path.relative_to(ROOT)) for path in breaches} & set(BOUNDARY_EXEMPT)
    assert [line for path, lines in breaches.items() if str(path.relative_to(ROOT)) not in exempt
            for line in lines] == []
    assert [name for name in sorted(exempt) if not breaches[ROOT / name]] == []  # no longer crosses: take it off


def test_the_boundary_check_finds_each_crossing(tmp_path):
    (tmp_path / "sumo_rail" / "sim").mkdir(parents=True)
    (tmp_path / "sumo_rail" / "sim" / "simulation.py").write_text(
        "def _load(): ...\nclass Simulation:\n    _api = None\n    def _start(self):\n        self._calls = 1\n")
    module = tmp_path / "sumo_rail" / "recordings" / "bad.py"
    module.parent.mkdir()
    module.write_text(
        "import os\nimport traci.constants\nfrom libsumo import vehicle\nfrom sumo_rail.sim.sumo_api import load_api\n"
        "from sumo_rail.sim.simulation import Simulation, _load\n"
        "class Scene(Simulation):\n    def _start(self):\n        super()._start()\n        self._own = 1\n"
        "class Other:\n    def _start(self, sim):\n        self._calls = sim._api\n        os._exit(0)\n"
        "        return sim.time_s, row._asdict()\n")
    private = sim_private_names(tmp_path)
    assert private == {"_load", "_api", "_start", "_calls"}
    assert boundary_breaches(module, private, tmp_path) == [
        "sumo_rail/recordings/bad.py:2 imports traci.constants",
        "sumo_rail/recordings/bad.py:3 imports libsumo",
        "sumo_rail/recordings/bad.py:4 imports sumo_rail.sim.sumo_api.load_api",
        "sumo_rail/recordings/bad.py:5 imports sumo_rail.sim.simulation._load",
        "sumo_rail/recordings/bad.py:7 overrides _start",
        "sumo_rail/recordings/bad.py:8 touches super()._start",
        "sumo_rail/recordings/bad.py:12 touches sim._api",
    ]
