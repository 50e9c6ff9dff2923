"""`python -m lab.bench`: the benchmarks (:func:`lab.bench.main`)."""

import sys

from lab.bench import main

sys.exit(main())
