"""The documentation's own Sphinx extension: pages and tables made from the code, so they cannot rot.

* **API pages** — at ``builder-inited`` one page per package of :data:`API_PAGES` is written to
  ``docs/reference/api/`` (generated, not committed): an ``automodule`` for each module under it,
  found by walking the package, so a new module appears without editing the docs. A module no
  page covers is a warning (and so a failed ``-W`` build).
* **Re-exported names** — a reference to ``hostlib.Device`` or ``protocol.Command`` (a name a
  package imports from the module that defines it) resolves to where the name is documented
  (``missing-reference``).
* **The protocol's tables** — ``{protocol-table} commands|states|functions|output-modes`` builds the
  table from :mod:`protocol.commands`, :mod:`protocol.states` and :mod:`protocol.ids`.
* **File formats** — ``{columns} module.CONSTANT`` holds a hand-written table of columns against
  the tuple of column names the writer uses: a column the code writes and the table lacks, or
  one the table names and the code no longer writes, is a warning.
* **Command parsers** — :func:`lab_bench_parser` hands sphinx-argparse the parser that
  ``python -m lab.bench`` builds inside its ``main``.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import os
import pkgutil
import re
import sys
import types
import typing
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.parsers.rst import Parser, directives
from docutils.utils import new_document
from sphinx.application import Sphinx
from sphinx.domains.python import PythonDomain
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
API_DIR = DOCS / "reference" / "api"

#: page name → (title, packages or modules it documents, recursively; an intro line).
API_PAGES: dict[str, tuple[str, tuple[str, ...], str]] = {
    "hostlib": ("hostlib — the public API", ("hostlib",),
                "What ``import hostlib`` gives, and the events and errors every layer shares."),
    "hostlib.track": ("hostlib.track — the step sum", ("hostlib.track",), ""),
    "hostlib.link": ("hostlib.link — sessions and devices", ("hostlib.link",), ""),
    "hostlib.aids": ("hostlib.aids — what the aids measure", ("hostlib.aids",), ""),
    "hostlib.calibration": ("hostlib.calibration — magnetometers and drift", ("hostlib.calibration",), ""),
    "hostlib.fusion": ("hostlib.fusion — the filters", ("hostlib.fusion",), ""),
    "hostlib.files": ("hostlib.files — CSV, GeoJSON, PNG, captures", ("hostlib.files",), ""),
    "hostlib.run": ("hostlib.run — a walk with live modules", ("hostlib.run",), ""),
    "hostlib.cli": ("hostlib.cli — openshoe-host", ("hostlib.cli",), ""),
    "protocol": ("protocol — the wire protocol, declared once", ("protocol",), ""),
    "firmware_sim": ("firmware_sim — the emulator's entry points", ("firmware_sim",),
                     "Where to start: :func:`firmware_sim.nav.firmware.build_module` builds a module, "
                     ":func:`firmware_sim.nav.warmup.prepare_module` prepares its compiled path, "
                     ":mod:`firmware_sim.transports.protocol_openshoe` is the ``openshoe://`` URL "
                     "handler, :mod:`firmware_sim.app.cli` is ``openshoe-emu``."),
    "firmware_sim.app": ("firmware_sim.app — what users run", ("firmware_sim.app",), ""),
    "firmware_sim.transports": ("firmware_sim.transports — how a host reaches a module",
                                ("firmware_sim.transports",), ""),
    "firmware_sim.links": ("firmware_sim.links — link models", ("firmware_sim.links",), ""),
    "firmware_sim.nav": ("firmware_sim.nav — the navigation firmware", ("firmware_sim.nav",), ""),
    "firmware_sim.mcu": ("firmware_sim.mcu — the µC runtime", ("firmware_sim.mcu",), ""),
    "firmware_sim.sensors": ("firmware_sim.sensors — sensor sources", ("firmware_sim.sensors",), ""),
    "tools": ("tools.conformance — openshoe-conformance", ("tools",), ""),
    "lab": ("lab — benchmarks and experiments (from a clone)", ("lab",), ""),
}

#: Modules not documented: a package's ``__main__`` runs its command when imported.
SKIP_MODULES = re.compile(r"(^|\.)__main__$")


def _walk(name: str) -> list[str]:
    """*name* and, for a package, every module under it (not its ``__main__``), sorted."""
    mod = importlib.import_module(name)
    found = [name]
    if hasattr(mod, "__path__"):
        for info in pkgutil.walk_packages(mod.__path__, prefix=name + "."):
            if not SKIP_MODULES.search(info.name):
                found.append(info.name)
    return sorted(found, key=lambda m: (m != name, m))


def api_modules() -> dict[str, list[str]]:
    """Page → the modules it documents; each module on exactly one page, the one of the longest
    package that holds it (``hostlib`` keeps what ``hostlib.link`` … leave: hostlib, errors, events)."""
    owner: dict[str, str] = {}
    for page, (_, roots, _) in sorted(API_PAGES.items(), key=lambda kv: -max(r.count(".") for r in kv[1][1])):
        for root in roots:
            for module in _walk(root):
                owner.setdefault(module, page)
    pages: dict[str, list[str]] = {page: [] for page in API_PAGES}
    for module, page in owner.items():
        pages[page].append(module)
    return {page: sorted(mods, key=lambda m: (m.count("."), m)) for page, mods in pages.items()}


def _page_text(page: str, title: str, intro: str, modules: list[str]) -> str:
    lines = [".. This page is generated by docs/_ext/openshoe_docs.py; edit API_PAGES there.", "",
             title, "=" * len(title), ""]
    if intro:
        lines += [intro, ""]
    if page == "hostlib":
        lines += _public_names_table()
    for module in modules:
        heading = f"``{module}``"
        lines += [heading, "-" * len(heading), "", f".. automodule:: {module}"]
        if module == "hostlib":
            lines += ["   :no-members:"]
        lines += [""]
    return "\n".join(lines) + "\n"


def _public_names_table() -> list[str]:
    """A list of ``hostlib.__all__``, each name linked to where it is documented."""
    import hostlib

    lines = ["The names ``hostlib`` exports, each documented where it is defined:", ""]
    for name in hostlib.__all__:
        target = canonical_name(f"hostlib.{name}")
        lines.append(f"* :py:obj:`hostlib.{name} <{target or 'hostlib.' + name}>`")
    return lines + [""]


def write_api_pages(app: Sphinx) -> None:
    """The API pages, written only where their text changed (so a rebuild stays incremental)."""
    API_DIR.mkdir(parents=True, exist_ok=True)
    pages = api_modules()
    wanted = set()
    for page, (title, _, intro) in API_PAGES.items():
        path = API_DIR / f"{page}.rst"
        wanted.add(path.name)
        text = _page_text(page, title, intro, pages[page])
        if not path.exists() or path.read_text() != text:
            tmp = path.with_suffix(f".tmp{os.getpid()}")
            tmp.write_text(text)
            os.replace(tmp, path)
    for stale in API_DIR.glob("*.rst"):
        if stale.name not in wanted:
            stale.unlink()


# -- names a package re-exports ------------------------------------------------------------------


_MISSING = object()


@functools.cache
def _import_attr(dotted: str) -> Any:
    """The object *dotted* names (a module, or an attribute chain under one); :data:`_MISSING`
    if none."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:i]))
        except Exception:  # noqa: BLE001 — not a module (or one that does not import): try shorter
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return _MISSING
        return obj
    return _MISSING


def canonical_name(dotted: str, documented: Any = ()) -> str | None:
    """Where the object *dotted* names is documented: ``module.qualname`` for a class or function,
    the module's name for a module, the owner class's place and the name for a member of a class
    (a method, a property, a dataclass field; an instance attribute or an annotation: the first
    class in the MRO where *documented* holds it), the module that defines it for data (the first
    of *documented* names whose module holds it); None when that is *dotted* itself or not found."""
    owner, _, attr = dotted.rpartition(".")
    holder = _import_attr(owner) if owner else _MISSING
    if isinstance(holder, type):  # a member: where the class that defines it is documented
        definer = next((k for k in holder.__mro__ if attr in vars(k)), None) or \
            next((k for k in holder.__mro__ if f"{k.__module__}.{k.__qualname__}.{attr}" in documented),
                 holder)
        place = f"{definer.__module__}.{definer.__qualname__}" if definer is not holder else \
            (canonical_name(owner) or owner)
        name = f"{place}.{attr}"
        return None if name == dotted else name
    obj = _import_attr(dotted)
    if obj is _MISSING:
        return None
    if isinstance(obj, types.ModuleType):
        name = obj.__name__
    elif isinstance(obj, (type, *_FUNCTION_TYPES)) and isinstance(getattr(obj, "__module__", None), str) \
            and "<" not in getattr(obj, "__qualname__", "<"):
        name = f"{obj.__module__}.{obj.__qualname__}"
    else:  # data: the module under the same package that defines it and is documented
        root = dotted.split(".")[0]
        name = next((f"{m}.{attr}" for m, mod in sorted(sys.modules.items())
                     if (m == root or m.startswith(root + ".")) and getattr(mod, attr, _MISSING) is obj
                     and f"{m}.{attr}" in documented), dotted)
    return None if name == dotted else name


_FUNCTION_TYPES = (types.FunctionType, types.BuiltinFunctionType, types.MethodType, property,
                   classmethod, staticmethod)


class IndexedPythonDomain(PythonDomain):
    """Sphinx's Python domain, but a reference that cannot match anything is answered at once.

    A type hint in a signature is looked up "fuzzily": Sphinx scans every documented object for a
    name ending in ``.name``, for each hint — and most hints (``float``, ``np.ndarray``, ``Path``)
    name nothing of the project's. Here such a lookup first asks an index of every dotted suffix
    of the documented names; where neither the suffix nor an exact name is there, the result is
    the one Sphinx's scan would give, nothing. Any other lookup is Sphinx's own."""

    _suffixes: set[str] = set()
    _indexed = -1

    def find_obj(self, env: Any, modname: str, classname: str, name: str, type: str | None,
                 searchmode: int = 0) -> list[tuple[str, Any]]:
        bare = name.removesuffix("()")
        if searchmode == 1 and bare:
            if self._indexed != len(self.objects):
                self._suffixes = {"." + ".".join(parts[i:]) for full in self.objects
                                  for parts in [full.split(".")] for i in range(1, len(parts))}
                self._indexed = len(self.objects)
            exact = {bare, f"{modname}.{bare}", f"{modname}.{classname}.{bare}"}
            if "." + bare not in self._suffixes and not exact & self.objects.keys():
                return []
        return super().find_obj(env, modname, classname, name, type, searchmode)


def resolve_reexport(app: Sphinx, env: Any, node: nodes.Element, contnode: nodes.Node) -> nodes.Node | None:
    """A Python reference Sphinx did not find: the name as the package re-exports it, resolved to
    the definition (tried as written, then under the current module and its parents); a type
    variable a signature names (``F`` of ``Callable[[F], F]``) is shown as its name."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip(".~")
    if isinstance(_import_attr(target), typing.TypeVar):  # a signature's type variable: its name, no link
        return contnode
    module = node.get("py:module") or ""
    klass = node.get("py:class") or ""
    candidates = [target]
    parts = module.split(".") if module else []
    for i in range(len(parts), 0, -1):
        prefix = ".".join(parts[:i])
        if klass:
            candidates.append(f"{prefix}.{klass}.{target}")
        candidates.append(f"{prefix}.{target}")
    domain = env.get_domain("py")
    for candidate in candidates:
        name = canonical_name(candidate, domain.objects)
        if name and name in domain.objects:
            new = node.deepcopy()
            new["reftarget"] = name
            new["refspecific"] = False
            return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], name, new, contnode)
    return None


# -- |x| in docstrings -------------------------------------------------------------------------

#: ``|x|``: the docstrings' absolute value or norm, which reStructuredText would take for a
#: substitution reference (the project defines none).
_BARS = re.compile(r"(?<![\\|\w])\|(?=[^\s|])([^|`\n]*?[^\s|\\])\|(?![|\w])")
#: Inline literals and interpreted text, left as they are.
_CODE = re.compile(r"(``.+?``|`[^`]+`)")


_RELATIVE_MOD = re.compile(r":mod:`(~?)\.([A-Za-z_][\w.]*)`")


def _absolute_modules(name: str, what: str, lines: list[str]) -> None:
    """``:mod:`.config``` in a docstring of ``firmware_sim.sensors.mpu9150`` means the sibling module
    ``firmware_sim.sensors.config``, as a relative import would; Sphinx would search every module
    named ``config`` instead. Rewrite such references to the module they name, where it exists."""
    module = name if what == "module" else name.rpartition(".")[0]
    while module and module not in sys.modules:
        module = module.rpartition(".")[0]
    if not module:
        return
    package = module if hasattr(sys.modules[module], "__path__") else module.rpartition(".")[0]

    def absolute(m: re.Match[str]) -> str:
        target = f"{package}.{m.group(2)}"
        return f":mod:`~{target}`" if target in sys.modules or _import_attr(target) is not _MISSING \
            else m.group(0)

    for i, line in enumerate(lines):
        if ":mod:`" in line:
            lines[i] = _RELATIVE_MOD.sub(absolute, line)


def process_docstring(app: Sphinx, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Every docstring autodoc renders: relative module references made absolute, ``|x|`` escaped."""
    _absolute_modules(name, what, lines)
    escape_bars(app, what, name, obj, options, lines)


def escape_bars(app: Sphinx, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Escape ``|x|`` outside literal blocks, inline literals, roles and tables, so that it shows
    as written instead of failing as an undefined substitution."""
    literal_indent: int | None = None
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if literal_indent is not None:
            if stripped and indent <= literal_indent:
                literal_indent = None
            else:
                continue
        if not re.match(r"(\|\s|\|$|\+[-=])", stripped):  # a line block or a grid table's line
            parts = _CODE.split(line)
            lines[i] = "".join(part if k % 2 else _BARS.sub(r"\\|\1\\|", part)
                               for k, part in enumerate(parts))
        if line.rstrip().endswith("::"):
            literal_indent = indent


# -- the protocol's tables -----------------------------------------------------------------------


def _list_table(header: list[str], rows: list[list[str]], widths: str | None = None) -> list[str]:
    lines = [".. list-table::", "   :header-rows: 1"]
    if widths:
        lines.append(f"   :widths: {widths}")
    lines.append("")
    for row in [header, *rows]:
        first = True
        for cell in row:
            text = cell.replace("\n", " ") or "\\ "
            lines.append(f"   {'* -' if first else '  -'} {text}")
            first = False
    return lines


def _payload_fields(construct: Any) -> str:
    subcons = getattr(construct, "subcons", None)
    if not subcons:
        return "—"
    out = []
    for sub in subcons:
        size = sub.sizeof()
        out.append(f"``{sub.name}`` ({size} B)")
    return ", ".join(out)


def commands_table() -> list[str]:
    from protocol.commands import CURRENT, LEGACY_2014

    rows = []
    for spec in CURRENT.values():
        legacy = (f"``0x{LEGACY_2014.spec(spec.command).wire_id:02X}``"
                  if LEGACY_2014.supports(spec.command) else "—")
        rows.append([f"``0x{spec.wire_id:02X}``", legacy, f"``{spec.name}``", str(spec.payload_len),
                     _payload_fields(spec.payload), "yes" if spec.acked else "no", spec.doc])
    return _list_table(["id (2015)", "id (2014)", "command", "payload [B]", "payload fields", "acked",
                        "what it does"], rows, "6 6 18 6 26 5 33")


def _state_type(spec: Any) -> str:
    kinds = {"f": "float", "i": "int", "u": "uint", "b": "bool"}
    dt = spec.dtype
    base = f"{kinds.get(dt.kind, dt.kind)}{dt.itemsize * 8}" if dt.kind != "b" else "bool"
    return base if not spec.shape else f"{base} × {' × '.join(str(n) for n in spec.shape)}"


def states_table() -> list[str]:
    from protocol.extensions import EXTENSION_STATES
    from protocol.states import STATES

    rows: list[list[str]] = []
    families: dict[str, list[Any]] = {}
    for sid, spec in STATES.items():
        family = re.sub(r"\d+", "{i}", spec.name) if re.match(r"(IMU\d+_|PS_DT\d+$)", spec.name) else None
        if family:
            families.setdefault(family, []).append(spec)
            if len(families[family]) > 1:
                continue
        rows.append([sid, spec, family])
    out = []
    for sid, spec, family in rows:
        if family:
            members = families[family]
            ident = f"``0x{members[0].id:02X}``–``0x{members[-1].id:02X}``"
            name = f"``{family}``"
            what = re.sub(r"\b(IMU|slot) \d+", r"\1 i", spec.doc) + f" (i = 0 … {len(members) - 1})"
        else:
            ident, name, what = f"``0x{sid:02X}``", f"``{spec.name}``", spec.doc
        if sid in EXTENSION_STATES:
            what += " — *emulator extension*"
        out.append([ident, name, str(spec.size), _state_type(spec), what])
    return _list_table(["id", "state", "size [B]", "type (big-endian)", "what it holds"], out,
                       "12 18 8 16 46")


def functions_table() -> list[str]:
    from protocol.ids import ProcId

    rows = [[f"``0x{p.value:02X}``", f"``{p.name}``",
             "emulator extension (the step's height from the ground's slope)"
             if p is ProcId.HEIGHT_COMPENSATION else ""] for p in ProcId]
    return _list_table(["id", "processing function", "note"], rows, "10 40 50")


def output_modes_table() -> list[str]:
    from protocol.ids import OutputMode

    notes = {"RATE_MASK": "the output divider d: 0 = off, else every 2^(d−1) loop cycles",
             "MAGNETOMETER": "OUTPUT_IMU_RD only", "INERTIAL": "OUTPUT_IMU_RD only",
             "TEMPERATURE": "OUTPUT_IMU_RD only", "LOSSLESS": "each packet is resent until acked",
             "PULL": "sent once when asked"}
    rows = [[f"``0x{m.value:02X}``", f"``{m.name}``", notes.get(m.name or "", "")] for m in OutputMode]
    return _list_table(["bits", "name", "meaning"], rows, "10 30 60")


TABLES = {"commands": commands_table, "states": states_table, "functions": functions_table,
          "output-modes": output_modes_table}


class ProtocolTable(SphinxDirective):
    """``{protocol-table} commands`` — a table made from the protocol package's registries."""

    required_arguments = 1

    def run(self) -> list[nodes.Node]:
        which = self.arguments[0]
        if which not in TABLES:
            raise self.error(f"protocol-table: unknown table {which!r}; choose from {', '.join(TABLES)}")
        for module in ("protocol.commands", "protocol.states", "protocol.ids", "protocol.extensions"):
            self.env.note_dependency(importlib.import_module(module).__file__)
        return self.parse_rst(TABLES[which]())

    def parse_rst(self, lines: list[str]) -> list[nodes.Node]:
        return parse_rst(self, lines)


def parse_rst(directive: SphinxDirective, lines: list[str]) -> list[nodes.Node]:
    """*lines* parsed as reStructuredText, whichever parser reads the page (MyST reads a Markdown
    page, and would not know ``.. list-table::``)."""
    document = new_document(directive.get_location(), directive.state.document.settings)
    Parser().parse("\n".join(lines) + "\n", document)
    return list(document.children)


# -- file formats ------------------------------------------------------------------------------


class Columns(SphinxDirective):
    """``{columns} hostlib.files.export.CSV_COLUMNS`` with a body of ``name: meaning`` lines, one per
    column (``P_{r}_{c}``-style patterns allowed): a table, checked against the code's tuple."""

    required_arguments = 1
    has_content = True
    option_spec = {"prefix": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        dotted = self.arguments[0]
        actual = _import_attr(dotted)
        if actual is None:
            raise self.error(f"columns: {dotted} not found")
        module = importlib.import_module(dotted.rsplit(".", 1)[0])
        self.env.note_dependency(module.__file__)
        entries: list[tuple[str, str]] = []
        for line in self.content:
            if not line.strip():
                continue
            name, _, meaning = line.partition(":")
            entries.append((name.strip().strip("`"), meaning.strip()))
        patterns = [(re.compile("^" + re.sub(r"\\\{[^}]*\\\}", "[^_]+", re.escape(n)) + "$"), n)
                    for n, _ in entries]
        actual = [str(c) for c in actual]
        for column in actual:
            if not any(p.match(column) for p, _ in patterns):
                logger.warning("columns %s: the code writes column %r, which the table lacks", dotted, column,
                               location=self.get_location())
        for pattern, name in patterns:
            if not any(pattern.match(c) for c in actual):
                logger.warning("columns %s: the table names %r, which the code no longer writes",
                               dotted, name, location=self.get_location())
        rows = [[f"``{name}``", meaning] for name, meaning in entries]
        return parse_rst(self, _list_table(["column", "meaning"], rows, "30 70"))


# -- the commands' parsers, for sphinx-argparse ---------------------------------------------------


def _escaped(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """*parser* with ``|`` in its texts escaped: sphinx-argparse reads them as reStructuredText, in
    which ``|METRIC|`` would be a substitution (the command's own ``--help`` is unchanged: the
    parser is built anew for the docs)."""
    if parser.description:
        parser.description = parser.description.replace("|", "\\|")
    for action in parser._actions:
        if action.help and action.help is not argparse.SUPPRESS:
            action.help = action.help.replace("|", "\\|")
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                if choice.help:
                    choice.help = choice.help.replace("|", "\\|")
            for sub in {id(p): p for p in action.choices.values()}.values():  # aliases once
                _escaped(sub)
    return parser


def emu_parser() -> argparse.ArgumentParser:
    """``openshoe-emu``'s parser (:func:`firmware_sim.app.cli.build_parser`)."""
    from firmware_sim.app.cli import build_parser

    return _escaped(build_parser())


def demo_parser() -> argparse.ArgumentParser:
    """The demo's parser (:func:`firmware_sim.app.demo.build_parser`)."""
    from firmware_sim.app.demo import build_parser

    return _escaped(build_parser())


def host_parser() -> argparse.ArgumentParser:
    """``openshoe-host``'s parser (:func:`hostlib.cli.app.build_parser`)."""
    from hostlib.cli.app import build_parser

    return _escaped(build_parser())


def conformance_parser() -> argparse.ArgumentParser:
    """``openshoe-conformance``'s parser (:func:`tools.conformance.cli.build_parser`)."""
    from tools.conformance.cli import build_parser

    return _escaped(build_parser())


def accuracy_parser() -> argparse.ArgumentParser:
    """``python -m lab.accuracy``'s parser (:func:`lab.accuracy.cli.build_parser`)."""
    from lab.accuracy.cli import build_parser

    return _escaped(build_parser())


def spread_parser() -> argparse.ArgumentParser:
    """``python -m lab.spread``'s parser (:func:`lab.spread.cli.build_parser`)."""
    from lab.spread.cli import build_parser

    return _escaped(build_parser())


# -- command parsers built inside a main() -------------------------------------------------------


class _Captured(Exception):
    def __init__(self, parser: argparse.ArgumentParser):
        self.parser = parser


def lab_bench_parser() -> argparse.ArgumentParser:
    """The parser ``python -m lab.bench`` builds in its ``main`` (caught as it starts to parse)."""
    import lab.bench

    def capture(self: argparse.ArgumentParser, *args: Any, **kwargs: Any) -> Any:
        raise _Captured(self)

    original = argparse.ArgumentParser.parse_args
    argparse.ArgumentParser.parse_args = capture  # type: ignore[method-assign]
    try:
        lab.bench.main([])
    except _Captured as caught:
        return _escaped(caught.parser)
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]
    raise RuntimeError("python -m lab.bench built no parser")


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_domain(IndexedPythonDomain, override=True)
    app.connect("builder-inited", write_api_pages)
    app.connect("missing-reference", resolve_reexport)
    app.connect("autodoc-process-docstring", process_docstring)
    app.add_directive("protocol-table", ProtocolTable)
    app.add_directive("columns", Columns)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
