"""The documentation site builds with every warning an error (``sphinx -W``): a docstring's broken
reference, a page's dead link, an image no command made, a column the code no longer writes."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import time

import pytest

from .examples import ROOT

NEEDED = ("sphinx", "myst_parser", "sphinxarg")


@pytest.mark.slow
@pytest.mark.skipif(any(importlib.util.find_spec(m) is None for m in NEEDED),
                    reason="needs sphinx, myst-parser and sphinx-argparse (the docs' dev dependencies)")
def test_the_site_builds_without_warnings(tmp_path):
    start = time.monotonic()
    # one process: beside the other tests, Sphinx's parallel build only adds its processes' costs
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-j", "1", "-q",
                           "-b", "html", "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"),
                           str(tmp_path / "html")],
                          capture_output=True, text=True, timeout=1200, cwd=ROOT)
    took = time.monotonic() - start
    assert done.returncode == 0, f"sphinx -W failed after {took:.0f} s:\n{done.stderr[-8000:]}"
    assert (tmp_path / "html" / "index.html").is_file()
    protocol_page = (tmp_path / "html" / "reference" / "protocol.html").read_text()
    assert "STEPWISE_DEAD_RECKONING" in protocol_page
    print(f"\nthe site built in {took:.1f} s")
