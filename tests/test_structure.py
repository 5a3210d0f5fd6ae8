"""The package's shape: imports follow the data flow (no import circles, none up the layers) and stand at the top
of each module, where a reader sees the real graph; no module is longer than a reader can hold."""

import ast
import os
from pathlib import Path

import pytest

from tests import TEST_XLA_FLAGS, known_to_xla

PACKAGE = Path(__file__).resolve().parents[1] / "dragmesh2_jax"
#: The data flow, bottom to top: a module imports only from its own floor or below.
FLOORS = (
    ("errors", "io", "progress"),
    ("assets",),
    ("scene",),
    ("trajectory", "physics"),
    ("task",),
    ("policies",),
    ("ppo",),
    ("baselines",),
    ("evaluation",),
    ("render", "viewer"),
    ("runs",),
    ("reproduce", "demo", "bench"),
    ("cli",),
)
FLOOR = {room: i for i, rooms in enumerate(FLOORS) for room in rooms}
#: Optional packages imported where they are used, so the package works without them.
OPTIONAL = {"mediapy", "warp", "wandb"}
#: The most lines a module may have: a longer one holds several ideas (a package of modules, one each, reads better).
MAX_LINES = 500


def _paths() -> dict[str, Path]:
    """Each module of the package by its dotted name."""
    return {".".join(("dragmesh2_jax", *p.relative_to(PACKAGE).with_suffix("").parts)).removesuffix(".__init__"): p
            for p in sorted(PACKAGE.rglob("*.py"))}


def _modules() -> dict[str, ast.Module]:
    return {name: ast.parse(path.read_text(), str(path)) for name, path in _paths().items()}


def _imports(tree: ast.Module, top_only: bool):
    body = tree.body if top_only else ast.walk(tree)
    for node in body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module
        elif isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif top_only and isinstance(node, ast.With):  # an import inside a top-level `with` is still at the top
            yield from _imports(ast.Module(body=node.body, type_ignores=[]), True)


def _room(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "dragmesh2_jax" and len(parts) > 1 else None


def test_every_room_of_the_package_has_a_floor():
    rooms = {_room(m) for m in _modules()} - {None}
    assert rooms <= set(FLOOR), rooms - set(FLOOR)


def test_imports_stand_at_the_top_of_each_module():
    late = [(m, i) for m, tree in _modules().items() for i in set(_imports(tree, False)) - set(_imports(tree, True))
            if i.split(".")[0] not in OPTIONAL]
    assert not late, late


def test_no_import_runs_up_the_layers():
    upward = [(m, i) for m, tree in _modules().items() for i in _imports(tree, True)
              if _room(m) and _room(i) and FLOOR[_room(i)] > FLOOR[_room(m)]]
    assert not upward, upward


def test_no_import_circles():
    modules = _modules()
    graph = {m: {i for i in _imports(tree, True) if i in modules and i != m} for m, tree in modules.items()}
    state: dict[str, int] = {}  # 1: on the path, 2: done

    def visit(m, path):
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                raise AssertionError(f"import circle: {' -> '.join([*path[path.index(n):], n])}")
            if n not in state:
                visit(n, [*path, n])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])


def test_no_module_is_over_max_lines():
    lengths = {m: len(path.read_text().splitlines()) for m, path in _paths().items()}
    assert {m: n for m, n in lengths.items() if n > MAX_LINES} == {}


def test_every_folder_of_the_package_is_a_regular_package():
    """setuptools' package finder ships only folders with an ``__init__.py``: a namespace folder works in an
    editable install and is missing from a wheel."""
    folders = {p.parent for p in PACKAGE.rglob("*.py")}
    assert [str(f) for f in sorted(folders) if not (f / "__init__.py").exists()] == []


@pytest.mark.xdist_group("structure")
def test_a_group_of_tests_stays_on_one_worker(request):
    """Under ``--dist loadgroup`` (pyproject's addopts) a test marked ``xdist_group`` carries its group in its id, which
    is how xdist keeps a module's trained-run fixtures on one worker (pytest 9.2 dropped the suffix: the modules'
    runs were trained on both workers)."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        pytest.skip("not run by an xdist worker")
    assert request.config.getoption("loadgroup") and request.node.nodeid.endswith("@structure")


def test_the_tests_compile_with_the_xla_flags_the_installed_xla_knows():
    """An unknown flag would abort every test process; a known one is set for the whole suite (tests/__init__.py)."""
    assert not known_to_xla("--xla_no_such_flag_anywhere=1")
    assert known_to_xla(TEST_XLA_FLAGS[0])  # the optimisation level: XLA's oldest of them
    for flag in TEST_XLA_FLAGS:
        assert (flag in os.environ["XLA_FLAGS"].split()) == known_to_xla(flag)
