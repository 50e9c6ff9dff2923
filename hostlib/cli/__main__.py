"""``python -m hostlib.cli``: the ``openshoe-host`` command line."""

import sys

from .app import main

sys.exit(main())
