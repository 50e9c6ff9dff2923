"""`python -m tools.bench` = `openshoe-bench`."""

import sys

from tools.bench import main

sys.exit(main())
