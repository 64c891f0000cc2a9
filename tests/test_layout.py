"""The package layout's direction of imports: the packages that compute (core types, human model,
mesh, morph, contacts, robot, fit, whole-body solve, balance, arms, reduction, metrics) never
import the command line, the API, the pipelines, the evaluator, the viewers and plots, the file
readers and writers or the physics check. Read from the source with ``ast`` (every import,
also those inside functions), so a lazy import counts too."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "imesh"

#: Packages and modules that compute: DESIGN.md's stages from the markers to the robot motion.
SOLVERS = ("core", "human", "mesh", "morph", "contacts", "robot", "fit", "solve", "balance",
           "arms", "reduction", "metrics")


def _forbidden(unit: str) -> bool:
    """Whether ``unit`` (a first-level name under imesh) is the command line, the API, a pipeline,
    the evaluator, a viewer or plot, a reader or writer, or the physics check."""
    return unit in ("cli", "__main__", "api", "pipeline", "evaluate", "viz", "io", "physics")


def _imported_units(path: Path) -> set[str]:
    """First-level imesh names that the module at ``path`` imports (absolute or relative)."""
    rel = path.relative_to(PACKAGE)
    package = list(rel.parent.parts)
    units = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names: list[list[str]] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                if node.module:
                    names.append(base + node.module.split("."))
                else:
                    names += [base + [alias.name] for alias in node.names]
            elif node.module and node.module.split(".")[0] == "imesh":
                names.append(node.module.split(".")[1:])
                if node.module == "imesh":
                    names += [[alias.name] for alias in node.names]
        elif isinstance(node, ast.Import):
            names += [alias.name.split(".")[1:] for alias in node.names
                      if alias.name.split(".")[0] == "imesh"]
        units |= {n[0] for n in names if n}
    return units


def _files(unit: str) -> list[Path]:
    folder = PACKAGE / unit
    return sorted(folder.rglob("*.py")) if folder.is_dir() else [PACKAGE / f"{unit}.py"]


@pytest.mark.parametrize("unit", SOLVERS)
def test_solvers_import_no_cli_viewer_reader_or_physics(unit):
    files = _files(unit)
    assert files and all(f.is_file() for f in files), f"imesh/{unit} not found"
    bad = {f"{f.relative_to(PACKAGE.parent)} imports imesh.{u}"
           for f in files for u in _imported_units(f) if _forbidden(u)}
    assert not bad, "\n".join(sorted(bad))


def test_the_check_sees_imports():
    """The reader finds a known import, relative and lazy: the CLI imports the viewers."""
    assert "viz" in _imported_units(PACKAGE / "cli" / "view.py")
    assert "physics" in _imported_units(PACKAGE / "evaluate" / "scoreboard.py")


#: Packages every package may import; docs/architecture.md says so instead of drawing them.
EVERYWHERE = ("core", "errors")
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"


def _package_graph() -> set[tuple[str, str]]:
    """(importer, imported) pairs of first-level imesh packages, from every module's imports."""
    edges = set()
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE)
        if len(rel.parts) == 1:  # the root's modules (__init__, __main__, api, errors)
            unit = rel.stem
        else:
            unit = rel.parts[0]
        edges |= {(unit, u) for u in _imported_units(path)
                  if u != unit and u not in EVERYWHERE and not u.startswith("__")}
    return {(a, b) for a, b in edges if not a.startswith("__") and a not in EVERYWHERE}


def _drawn_edges() -> set[tuple[str, str]]:
    """The arrows ``a --> b`` of the first mermaid diagram in docs/architecture.md."""
    block = re.search(r"```mermaid\n(.*?)```", ARCHITECTURE.read_text(), re.S)
    assert block, f"{ARCHITECTURE}: no mermaid diagram"
    return set(re.findall(r"^\s*(\w+)\s*-->\s*(\w+)\s*$", block.group(1), re.M))


def test_the_architecture_diagram_is_the_import_graph():
    """docs/architecture.md draws exactly the imports between packages: an import added or
    removed in the code must be drawn or erased there."""
    drawn, actual = _drawn_edges(), _package_graph()
    assert drawn == actual, (f"imported but not drawn: {sorted(actual - drawn)}; "
                             f"drawn but not imported: {sorted(drawn - actual)}")


def test_core_imports_nothing_of_imesh_but_errors():
    """core/ holds the shared types: it may import only errors (no stage, no reader)."""
    used = {u for f in _files("core") for u in _imported_units(f)} - {"core", "errors"}
    assert not used, f"imesh/core imports {sorted(used)}"


def _heavy_imports(path: Path) -> set[str]:
    """Top-level names of the modules ``path`` imports, also through ``optional("name", ...)``
    (imesh.core.lazy)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
        elif (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "optional"
              and node.args and isinstance(node.args[0], ast.Constant)):
            found.add(str(node.args[0].value).split(".")[0])
    return found


@pytest.mark.parametrize(("module", "home"), [("pinocchio", "robot"), ("dartpy", "physics")])
def test_pinocchio_only_in_robot_and_dart_only_in_physics(module, home):
    outside = sorted(str(f.relative_to(PACKAGE)) for f in PACKAGE.rglob("*.py")
                     if f.relative_to(PACKAGE).parts[0] != home and module in _heavy_imports(f))
    assert not outside, f"{module} imported outside imesh/{home}/: {outside}"
    assert any(module in _heavy_imports(f) for f in _files(home)), "the check sees nothing"
