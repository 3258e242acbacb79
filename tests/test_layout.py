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
