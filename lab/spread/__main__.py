"""`python -m lab.spread`: the spread of many walks' ends (:func:`lab.spread.main`)."""

import sys

from lab.spread import main

sys.exit(main())
