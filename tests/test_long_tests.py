"""The list of long tests that a run on several processes deals out first (tests/conftest.py) names
tests that exist: a renamed test or docs example would otherwise fall back among the short ones and
leave one worker running it alone at the end."""

from __future__ import annotations

import re

from .conftest import LONG_TESTS, REPO
from .docs.examples import code_blocks


def test_every_long_test_entry_names_a_test_file_or_folder_and_function_that_exist():
    examples = {block.name for block in code_blocks()}
    missing = []
    for key in LONG_TESTS:
        path, _, rest = key.partition("::")
        if not (REPO / path).exists():
            missing.append(key)
            continue
        if not rest:
            continue
        function, _, param = rest.partition("[")
        if not re.search(rf"^def {re.escape(function)}\(", (REPO / path).read_text(), re.M):
            missing.append(key)
        elif param and function == "test_example_runs" and param.rstrip("]") not in examples:
            missing.append(key)
    assert missing == []
