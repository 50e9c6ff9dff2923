"""The documentation's examples: found in the pages, classified by their marker, and turned into
scripts a test runs.

A shell (``sh``, ``bash``, ``shell``, ``console``) or Python (``python``, ``py``) block in
README.md, docs/ or hostlib/README.md carries a marker on the line before its opening fence:

* ``<!-- example -->`` — it runs; ``<!-- example: OLD => NEW; … -->`` runs it with each OLD
  replaced by NEW (a short scenario, fewer seeds) — the substitution stands beside the block;
* ``<!-- needs-hardware -->`` — a device (``/dev/rfcomm0``) or other machines: not run, but each
  command's options are parsed by the command's own parser (a Python block is compiled);
* ``<!-- long-run -->`` — an experiment of minutes: parsed as above, and run with
  ``OPENSHOE_DOCS_LONG=1``;
* ``<!-- not-run: why -->`` — installs, or the Makefile's own targets (held to the Makefile).

A block with ``<!-- file: NAME -->`` before it is written as NAME into every example's folder
(the sweep spec a page shows is the one its example reads).

How an example runs: in a folder of its own holding the fixtures (:mod:`tests.docs.conftest`),
with ``openshoe-emu``, ``openshoe-host``, ``openshoe-conformance`` and ``python`` resolved to the
project's interpreter (``python -m …``), ``/tmp/`` moved into the example's folder,
``../shared/`` to the shared data beside the clone and ``lab/…`` (a file of the clone, which the
pages read from the clone's root) to the clone's; ``openshoe-emu serve`` stops by itself
(``--duration``: a fifth of a second in the foreground, standing still unless the block names a scenario,
60 s in the background, where the next command waits for its READY line) and every background job is
stopped when the block ends.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared"

SHELL = {"sh", "bash", "shell", "console"}
PYTHON = {"python", "py"}
KINDS = ("example", "needs-hardware", "long-run", "not-run")

_FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*\{?([\w-]*)\}?\s*(.*)$")
_MARKER = re.compile(r"^\s*<!--\s*(example|needs-hardware|long-run|not-run|file)\s*(?::\s*(.*?))?\s*-->\s*$")


@dataclass
class Block:
    """One fenced block of a page."""

    page: Path  #: relative to the repository
    line: int  #: the opening fence's line (1-based)
    lang: str
    text: str
    kind: str | None = None  #: the marker's kind, None when unmarked
    detail: str = ""  #: what follows the marker's colon
    subs: list[tuple[str, str]] = field(default_factory=list)

    @property
    def is_code(self) -> bool:
        return self.lang in SHELL | PYTHON

    @property
    def name(self) -> str:
        return f"{self.page}:{self.line}"


def pages() -> list[Path]:
    """README.md, hostlib/README.md and every page of docs/ (not the build, not generated pages)."""
    docs = sorted(p for p in (ROOT / "docs").rglob("*.md")
                  if "_build" not in p.parts and not p.is_relative_to(ROOT / "docs" / "reference" / "api"))
    return [ROOT / "README.md", ROOT / "hostlib" / "README.md", *docs]


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of *path*, each with the marker on the line before it."""
    lines = path.read_text().splitlines()
    out: list[Block] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang = m.group(2), m.group(3).lower()
        j = i + 1
        while j < len(lines) and not lines[j].strip().startswith(fence):
            j += 1
        block = Block(path.relative_to(ROOT), i + 1, lang, "\n".join(lines[i + 1:j]) + "\n")
        k = i - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        marker = _MARKER.match(lines[k]) if k >= 0 else None
        if marker:
            block.kind, block.detail = marker.group(1), (marker.group(2) or "").strip()
            if block.kind == "example" and block.detail:
                block.subs = [tuple(s.strip() for s in part.split("=>", 1))  # type: ignore[misc]
                              for part in block.detail.split(";") if "=>" in part]
        out.append(block)
        i = j + 1
    return out


def all_blocks() -> list[Block]:
    return [b for p in pages() for b in blocks(p)]


def code_blocks() -> list[Block]:
    return [b for b in all_blocks() if b.is_code]


def page_files() -> dict[str, str]:
    """The blocks marked ``<!-- file: NAME -->``: name → text."""
    return {b.detail: b.text for b in all_blocks() if b.kind == "file"}


def substituted(block: Block, tmp: Path) -> str:
    """The block's text with its substitutions, ``/tmp/`` in *tmp*, ``../shared/`` and ``lab/`` found."""
    text = block.text
    for old, new in block.subs:
        if old not in text:
            raise AssertionError(f"{block.name}: the substitution {old!r} matches nothing")
        text = text.replace(old, new)
    text = re.sub(r"(?<![\w.])/tmp/", f"{tmp}/", text)
    text = re.sub(r"(?<![\w./-])lab/", f"{ROOT}/lab/", text)
    return text.replace("../shared/", f"{SHARED}/")


#: What a ``serve`` in the foreground walks when its block names no route: no host talks to it in
#: its fifth of a second, which would not reach the default route's first step, and the default route's
#: sensors take seconds to simulate before the READY line.
IDLE_SCENARIO = "stand:3"

_SERVE = re.compile(r"^(\s*openshoe-emu serve\b[^#&]*?)\s*(&)?\s*(#.*)?$")


def shell_script(block: Block, tmp: Path) -> str:
    """The bash script that runs a shell block (module doc)."""
    out = ["set -euo pipefail",
           'wait_ready() { for _ in $(seq 1 900); do grep -q READY "$1" 2>/dev/null && return 0; '
           'sleep 0.1; done; echo "no READY in $1:" >&2; cat "$1" >&2; return 1; }',
           "trap 'kill $(jobs -p) 2>/dev/null || true; wait 2>/dev/null || true' EXIT"]
    served = 0
    for line in substituted(block, tmp).splitlines():
        m = _SERVE.match(line)
        if not m:
            out.append(line)
            continue
        command, background = m.group(1), bool(m.group(2))
        if "--duration" not in command:
            command += " --duration 60" if background else " --duration 0.2"
        if not background and "--scenario" not in command and "--replay" not in command:
            command += f" --scenario {IDLE_SCENARIO}"
        if background:
            served += 1
            log = f"serve{served}.out"
            out.append(f"{command} > {log} 2>&1 &")
            out.append(f"wait_ready {log}")
        else:
            out.append(command)
    return "\n".join(out) + "\n"


def joined_commands(text: str) -> list[str]:
    """The block's commands: continuation lines joined, comments and heredoc bodies left out."""
    commands: list[str] = []
    pending = ""
    heredoc: str | None = None
    for raw in text.splitlines():
        if heredoc is not None:
            if raw.strip() == heredoc:
                heredoc = None
            continue
        line = pending + raw
        if line.rstrip().endswith("\\"):
            pending = line.rstrip()[:-1] + " "
            continue
        pending = ""
        h = re.search(r"<<-?\s*'?(\w+)'?", line)
        if h:
            heredoc = h.group(1)
        if line.strip() and not line.strip().startswith("#"):
            commands.append(line.strip())
    return commands


#: The parser of each command a page runs: (words that name it, "module:function").
PARSERS: list[tuple[tuple[str, ...], str]] = [
    (("openshoe-emu",), "firmware_sim.app.cli:build_parser"),
    (("openshoe-host",), "hostlib.cli.app:build_parser"),
    (("openshoe-conformance",), "tools.conformance.cli:build_parser"),
    (("python", "-m", "firmware_sim.app.demo"), "firmware_sim.app.demo:build_parser"),
    (("python", "-m", "lab.accuracy"), "lab.accuracy.cli:build_parser"),
    (("python", "-m", "lab.spread"), "lab.spread.cli:build_parser"),
    (("python", "-m", "lab.bench"), "lab.bench:main"),
]


def parse_jobs(block: Block) -> list[tuple[str, list[str]]]:
    """For each command of *block* with a known parser: (the parser, its arguments)."""
    jobs = []
    for command in joined_commands(block.text):
        words = shlex.split(command.split(" > ")[0].rstrip("& "), comments=True)
        while words and re.match(r"^[A-Z_]+=", words[0]):  # VAR=value before the command
            words.pop(0)
        for head, parser in PARSERS:
            if tuple(words[:len(head)]) == head:
                jobs.append((parser, words[len(head):]))
                break
    return jobs
