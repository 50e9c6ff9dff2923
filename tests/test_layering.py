"""The layers of the code base, as docs/design.md draws them, checked on the sources.

Every import counts: at module level, inside functions, and under
``TYPE_CHECKING``. The rules:

* ``protocol`` holds declarations only: it imports no other package of the
  project and does no I/O;
* the µC runtime (``firmware_sim.mcu``) never imports navigation, sensors,
  link models, transports or the applications: what it runs is handed to it;
* the navigation firmware (``firmware_sim.nav``) never imports link models,
  transports or the applications;
* link models never import transports or the applications, and transports
  never import the applications;
* inside the host SDK the sub-packages stack one way, each importing only those below it: the
  shared ``errors`` and ``events``; ``track`` (the step sum); ``link`` (ports, session, device) and
  ``aids`` (what the aids measure); ``calibration``; ``fusion`` (the filter core and its
  trackers); ``files`` (export, plot, capture replay); ``run`` (carrying out a walk); ``web`` (a
  walk's live page); ``cli``. The link knows nothing of the fusion, and the fusion does no I/O;
* the host SDK's data path (``hostlib`` but its plot, its live page's server and command line) uses only
  the standard library, ``protocol``, pyserial, numpy, and the maintained libraries
  for what it reads and converts: pynmea2 (NMEA), pymap3d (geodesy) and
  pygeomag (the World Magnetic Model);
* nothing the package ships (``protocol``, ``firmware_sim``, ``hostlib``, ``tools``) imports the
  lab (``lab``: the benchmarks and the papers' experiments, run from a clone, not installed); the
  lab may import all of them;
* no two project modules import each other, directly or round a longer cycle;
* no project module is named like a standard-library module.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("protocol", "firmware_sim", "hostlib", "tools", "lab")
#: Modules whose use means I/O (files, sockets, devices, processes, threads).
IO_MODULES = {"io", "os", "socket", "serial", "select", "selectors", "subprocess", "threading", "pty", "tty",
              "termios", "fcntl", "shutil", "tempfile", "pathlib", "sys", "asyncio", "signal"}
IO_CALLS = {"open", "print", "input"}


def module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@cache
def project_modules() -> dict[str, Path]:
    return {module_name(p): p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py")}


def _resolve(name: str, current: str, is_package: bool, level: int) -> str:
    if not level:
        return name
    base = current.split(".") if is_package else current.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports_of(mod: str) -> Iterator[tuple[str, int]]:
    """(imported module, line) for every import in *mod*; ``from pkg import sub`` names the submodule."""
    path = project_modules()[mod]
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(node.module or "", mod, is_package, node.level)
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                yield (sub if sub in project_modules() else target), node.lineno


def project_imports(mod: str) -> set[str]:
    out = set()
    for name, _line in imports_of(mod):
        while name and name not in project_modules():
            name = name.rpartition(".")[0]
        if name and name != mod:
            out.add(name)
    return out


def under(mod: str, *prefixes: str) -> bool:
    return any(mod == p or mod.startswith(p + ".") for p in prefixes)


def violations(layer: str, forbidden: tuple[str, ...]) -> list[str]:
    return [f"{mod} imports {dep}" for mod in sorted(project_modules()) if under(mod, layer)
            for dep in sorted(project_imports(mod)) if under(dep, *forbidden)]


def test_protocol_declares_and_imports_no_other_layer():
    assert violations("protocol", ("firmware_sim", "hostlib", "tools", "lab")) == []


def test_protocol_does_no_io():
    found = []
    for mod in project_modules():
        if not under(mod, "protocol"):
            continue
        for name, line in imports_of(mod):
            if name.split(".")[0] in IO_MODULES:
                found.append(f"{mod}:{line} imports {name}")
        tree = ast.parse(project_modules()[mod].read_text())
        found += [f"{mod}:{n.lineno} calls {n.func.id}()" for n in ast.walk(tree)
                  if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in IO_CALLS]
    assert found == []


@pytest.mark.parametrize(("layer", "forbidden"), [
    ("firmware_sim.mcu", ("firmware_sim.nav", "firmware_sim.sensors", "firmware_sim.links",
                          "firmware_sim.transports", "firmware_sim.app", "hostlib", "tools")),
    ("firmware_sim.nav", ("firmware_sim.links", "firmware_sim.transports", "firmware_sim.app",
                          "hostlib", "tools")),
    ("firmware_sim.sensors", ("firmware_sim.nav", "firmware_sim.links", "firmware_sim.transports",
                              "firmware_sim.app", "hostlib", "tools")),
    ("firmware_sim.links", ("firmware_sim.transports", "firmware_sim.app", "hostlib", "tools")),
    ("firmware_sim.transports", ("firmware_sim.app", "tools")),
    ("firmware_sim.board", ("firmware_sim.mcu", "firmware_sim.nav", "firmware_sim.sensors")),
    ("hostlib", ("firmware_sim", "tools")),
])
def test_a_layer_never_imports_the_layers_above_it(layer, forbidden):
    assert violations(layer, forbidden) == []


@pytest.mark.parametrize("layer", ["protocol", "firmware_sim", "hostlib", "tools"])
def test_nothing_the_package_ships_imports_the_lab(layer):
    assert violations(layer, ("lab",)) == []


def test_only_the_labs_own_tests_import_the_lab():
    """The tests of what the package ships (all but tests/lab) hold up without the lab."""
    found = []
    for path in sorted((REPO / "tests").rglob("*.py")):
        if path.is_relative_to(REPO / "tests" / "lab"):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else []
            found += [f"{path.relative_to(REPO)}:{node.lineno} imports {n}" for n in names if under(n, "lab")]
    assert found == []


#: hostlib's sub-packages from the bottom up: each may import only those before it.
HOST_LAYERS = ("hostlib.track", "hostlib.link", "hostlib.aids", "hostlib.calibration", "hostlib.fusion",
               "hostlib.files", "hostlib.run", "hostlib.web", "hostlib.cli")


@pytest.mark.parametrize("layer", HOST_LAYERS)
def test_a_host_sub_package_imports_only_the_ones_below_it(layer):
    above = HOST_LAYERS[HOST_LAYERS.index(layer) + 1:]
    assert violations(layer, above) == []


def test_the_link_knows_nothing_of_the_aids_and_the_aids_nothing_of_the_link():
    assert violations("hostlib.link", ("hostlib.aids",)) + violations("hostlib.aids", ("hostlib.link",)) == []


def test_the_fusion_does_no_io():
    """The filter and its trackers compute; they read no file, port or clock. (A lock is no I/O: two
    feet's devices hand their steps from two reader threads.)"""
    found = []
    for mod in project_modules():
        if not under(mod, "hostlib.fusion", "hostlib.track"):
            continue
        for name, line in imports_of(mod):
            top = name.split(".")[0]
            if top in IO_MODULES - {"threading"} or top == "time":
                found.append(f"{mod}:{line} imports {name}")
        tree = ast.parse(project_modules()[mod].read_text())
        found += [f"{mod}:{n.lineno} calls {n.func.id}()" for n in ast.walk(tree)
                  if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in IO_CALLS]
    assert found == []


def test_the_host_sdk_data_path_uses_only_protocol_pyserial_numpy_and_its_format_libraries():
    allowed_third_party = {"serial", "numpy", "pynmea2", "pymap3d", "pygeomag",
                           "typing_extensions"}  # the last for type checkers only
    stdlib = set(sys.stdlib_module_names)
    found = []
    for mod in project_modules():
        if not under(mod, "hostlib") or mod in ("hostlib.files.plot", "hostlib.cli", "hostlib.web.server"):
            continue
        for name, line in imports_of(mod):
            top = name.split(".")[0]
            if top in stdlib or top in allowed_third_party or top in ("hostlib", "protocol", "__future__"):
                continue
            found.append(f"{mod}:{line} imports {name}")
    assert found == []


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles_between_project_modules():
    """A package importing its own submodules (its ``__init__``) is not a cycle of modules."""
    graph = {m: {d for d in project_imports(m) if not m.startswith(d + ".")} for m in project_modules()}
    assert _cycles(graph) == []


def test_no_project_module_shadows_a_standard_library_module():
    shadows = [m for m in project_modules() if m.rpartition(".")[2] in sys.stdlib_module_names]
    assert shadows == []
