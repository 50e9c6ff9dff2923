"""`python -m tools.spread` = `openshoe-spread`."""

import sys

from tools.spread import main

sys.exit(main())
