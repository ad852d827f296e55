"""The package's layers: every import of a bridgefem module, lazy ones inside functions and TYPE_CHECKING ones
included, points down the data flow, and no two modules import each other, directly or round a circle.

The layers, lowest first: the data flows scene -> structure -> FE model -> joint laws -> solver -> search ->
analysis -> results. ``limit`` (the rigid-block LP and the conic bounds) sits below ``fe``: it is the FE's
independent check, so it never imports the FE, the solver or anything above them.
"""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bridgefem"
LAYERS = ("status petsc_start", "geometry", "scene", "structure", "laws", "limit", "fe", "solver", "search", "analysis", "assess", "io",
          "")
"""Subpackages (and the top-level modules ``status`` and ``petsc_start``, the bottom layer) from the bottom up; "" is
the package itself (its public API in ``__init__``/``api``, and ``__main__``), which may import anything."""
STARTS_PETSC = ("fe", "solver", "search", "analysis")
"""The subpackages whose ``__init__`` starts PETSc without the current folder's option files
(:func:`bridgefem.petsc_start.start`): the only ones whose modules may import PETSc or DOLFINx as they load."""


def _module(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every bridgefem module that ``path`` imports, wherever the import statement stands."""
    here = _module(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "bridgefem"}
        elif isinstance(node, ast.ImportFrom):
            base = node.module.split(".") if node.level == 0 else (
                package[:len(package) - node.level + 1] + (node.module.split(".") if node.module else []))
            if base[0] != "bridgefem":
                continue
            for alias in node.names:  # ``from pkg import module`` imports the module
                sub = ".".join(base + [alias.name])
                found.add(sub if (PACKAGE.parent / (sub.replace(".", "/") + ".py")).exists()
                          or (PACKAGE.parent / sub.replace(".", "/")).is_dir() else ".".join(base))
    return found


def _layer(module: str) -> int:
    parts = module.split(".")
    name = parts[1] if len(parts) > 1 else ""
    return next((i for i, layer in enumerate(LAYERS) if name in layer.split()), len(LAYERS) - 1)


GRAPH = {_module(p): _imports(p) - {_module(p)} for p in PACKAGE.rglob("*.py")}


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_point_down(module):
    """A module imports only from its own layer's package or the layers below it."""
    upward = sorted(m for m in GRAPH[module] if _layer(m) > _layer(module))
    sideways = sorted(m for m in GRAPH[module] if _layer(m) == _layer(module) not in (0, len(LAYERS) - 1)
                      and m.split(".")[:2] != module.split(".")[:2])
    assert not upward, f"{module} imports from a higher layer: {upward}"
    assert not sideways, f"{module} imports from another package of its layer: {sideways}"


def test_no_import_circles():
    """The module graph (lazy imports included) has no cycle: no module can reach itself."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for n in sorted(GRAPH.get(m, ())):
            if n not in GRAPH:
                continue
            if state.get(n) == 1:
                pytest.fail("import circle: " + " -> ".join(stack[stack.index(n):] + [n]))
            if n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(GRAPH):
        if m not in state:
            visit(m)


def test_limit_is_independent_of_the_fe():
    """The rigid-block LP and the conic bounds import nothing of the FE (nor DOLFINx or PETSc)."""
    paths = sorted((PACKAGE / "limit").rglob("*.py"))
    assert len(paths) > 1, "no limit package: the test proves nothing"
    for path in paths:
        text = path.read_text()
        assert "dolfinx" not in text and "petsc4py" not in text, path.name


@pytest.mark.parametrize("package", STARTS_PETSC)
def test_packages_using_petsc_start_it_first(package):
    """Each package that uses PETSc starts it (without rc files) in its ``__init__``, before any of its modules."""
    tree = ast.parse((PACKAGE / package / "__init__.py").read_text())
    calls = [n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)]
    assert "start" in calls, f"bridgefem/{package}/__init__.py does not call petsc_start.start()"


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_petsc_is_imported_only_where_it_was_started(path):
    """A module that imports PETSc, DOLFINx or UFL as it loads lies in a package of :data:`STARTS_PETSC` (elsewhere
    such an import would start PETSc with the current folder's option files); lazy imports inside functions run
    after the module's own imports, which start PETSc through one of those packages."""
    module = _module(path).split(".")
    if len(module) > 1 and module[1] in (*STARTS_PETSC, "petsc_start"):
        return
    heavy = ("petsc4py", "dolfinx", "ufl", "basix", "ffcx")
    for node in ast.parse(path.read_text()).body:
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
            [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
        assert not any(n.split(".")[0] in heavy for n in names), f"{path.name} imports {names} as it loads"


LIGHT_COMMANDS = ("lp", "min-thickness", "check")
"""The commands that answer from the scene and the rigid-block LP alone."""


@pytest.mark.parametrize("command", LIGHT_COMMANDS)
def test_rigid_block_commands_load_no_fe(command):
    """``bridgefem lp``, ``min-thickness`` and ``check`` answer without loading DOLFINx, PETSc, UFL, Gmsh,
    matplotlib or MPI (each is a process start of a few tenths of a second; the LP takes milliseconds)."""
    heavy = ("dolfinx", "petsc4py", "ufl", "gmsh", "matplotlib", "mpi4py")
    probe = ("import sys; from bridgefem.io.cli import main; code = main(sys.argv[1:]); "
             f"print(sorted(m for m in sys.modules if m.split('.')[0] in {heavy!r})); sys.exit(code)")
    scene = PACKAGE.parent / "demos" / "bare_arch.toml"
    proc = subprocess.run([sys.executable, "-c", probe, command, str(scene)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "[]"
