"""Sphinx configuration of the OpenShoe emulator's documentation (Sphinx + MyST).

Build: ``.venv/bin/python -m sphinx -W -j auto -b html docs docs/_build/html``.
The project's own extension (``docs/_ext/openshoe_docs.py``) generates the protocol's tables
from :mod:`protocol`, the API pages' module lists, the file formats' column checks, and
resolves references to names a package re-exports.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))  # protocol, firmware_sim, hostlib, tools and lab, as from a clone
sys.path.insert(0, str(DOCS / "_ext"))

project = "OpenShoe emulator"
author = "the OpenShoe emulator's authors"
copyright = "the OpenShoe emulator's authors"  # noqa: A001 (Sphinx's name)

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinxarg.ext",
    "openshoe_docs",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True,
                           "undoc-members": True}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_preserve_defaults = False  # True trips over some signatures ("pop from empty list")
autoclass_content = "both"

# The API pages document every module once, where it is defined; a name a package re-exports
# (hostlib.Device, protocol.Command …) resolves to that place (openshoe_docs.resolve_reexport).
add_module_names = False
python_use_unqualified_type_names = True

# Every cross-reference must resolve (with -W a broken one fails the build and make test), but for
# the standard library's and the other packages' types (no intersphinx without a network). Of the
# project's own references none is excepted (nitpick_ignore): a private name is written as a
# literal, an attribute a reference names has a doc comment (#:), and a name a page documents is
# public. Keep the list empty.
nitpicky = True
_EXTERNAL = ("collections|numpy|np|serial|argparse|threading|enum|datetime|distributed|types|tqdm|time|"
             "subprocess|socket|selectors|random|pathlib|os|matplotlib|importlib|dataclasses|contextlib|"
             "construct|concurrent|abc|typing|io|asyncio|aiohttp|json|csv|math|re|dask|pandas|pyarrow|"
             "numba|queue|functools|itertools")
nitpick_ignore_regex = [
    (r"py:.*", rf"({_EXTERNAL})\..*"),
    (r"py:.*", r"(ArrayLike|Callable|Path|dict|list|tuple)(\[.*)?"),
]
nitpick_ignore: list[tuple[str, str]] = []

html_theme = "alabaster"
html_title = "OpenShoe emulator"
html_static_path: list[str] = []
html_theme_options = {
    "description": "module emulator · wire protocol · host SDK",
    "fixed_sidebar": True,
    "page_width": "1180px",
    "sidebar_width": "260px",
    "show_relbars": True,
}
html_sidebars = {"**": ["about.html", "navigation.html", "searchbox.html"]}
