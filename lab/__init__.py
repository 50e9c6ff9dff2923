"""The lab: the benchmarks and the papers' experiments, run from a clone and not installed.

``python -m lab.bench`` (:mod:`lab.bench`), ``python -m lab.accuracy`` (:mod:`lab.accuracy`) and
``python -m lab.spread`` (:mod:`lab.spread`), from the repository's root. The lab may import every
package of the project; none of them imports the lab (``tests/test_layering.py``).
"""
