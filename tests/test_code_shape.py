"""The shape of the code a reader meets: short functions, and words of the domain.

* No function or method in the packages is longer than 120 lines (most are under
  60; a longer one says in a comment why it reads better as one piece).
* Code, docstrings and test names speak of the module and its behaviour, not of
  the project's planning (numbered work items, acceptance headings).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("protocol", "firmware_sim", "hostlib", "tools", "lab")
MAX_FUNCTION_LINES = 120
PLANNING_WORDS = re.compile(r"\bissue\s*#?\d+|\bmust[ _]show\b|\b(?:tracker|work) item", re.IGNORECASE)


def sources(*roots: str) -> list[Path]:
    return sorted(p for root in roots for p in (REPO / root).rglob("*.py"))


def test_no_function_is_longer_than_120_lines():
    long = []
    for path in sources(*PACKAGES):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(REPO)}:{node.lineno} {node.name} ({n} lines)")
    assert long == []


def test_code_and_tests_speak_of_the_module_and_its_behaviour():
    hits = []
    for path in sources(*PACKAGES, "tests"):
        if path.name == Path(__file__).name:
            continue
        rel = path.relative_to(REPO)
        if PLANNING_WORDS.search(str(rel)):
            hits.append(f"{rel}: file name")
        for k, line in enumerate(path.read_text().splitlines(), start=1):
            if PLANNING_WORDS.search(line):
                hits.append(f"{rel}:{k}: {line.strip()}")
    assert hits == []
