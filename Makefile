# The two commands a fresh clone needs:
#   make demo   set up .venv and run the main job (emulated walk tracked through a pty)
#   make test   set up .venv, lint with ruff, run the per-kernel equivalence tests with
#               OPENSHOE_PURE=1 (kernels as plain Python) and the docs site's build while the
#               kernels compile, then every other test on three processes
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
FILL_KERNEL_CACHE := from firmware_sim.app.cluster import prepare_process; prepare_process()

.PHONY: demo test lint setup clean docs

# The venv is filled by uv (installed into it by pip): the same packages as pip's, in a tenth of the
# time; by pip itself where uv cannot be had or cannot reach the packages.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	{ $(BIN)/pip install --quiet uv && $(BIN)/uv pip install --quiet --python $(BIN)/python -e '.[dev]'; } \
	  || $(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check .

# The tests start hundreds of fresh processes: each loads its modules' cached bytecode, also where the
# environment asks Python not to write it (PYTHONDONTWRITEBYTECODE, empty here: unset).
test: export PYTHONDONTWRITEBYTECODE =
# Its workers keep both cores busy: numpy's BLAS runs one thread in each (more only oversubscribe
# the cores; the numbers are the same, as Dask's workers already run it).
test: export OPENBLAS_NUM_THREADS = 1

# test: while the compiled kernels go into numba's on-disk cache on one core (once, not in each
# worker), the other runs what needs no compiled kernel: the per-kernel tests' plain-Python forms
# (OPENSHOE_PURE=1) and the docs site's build, its report kept until the end. Once the kernels are
# in the cache every other test starts on three workers (two cores: a third fills the time a test
# waits on a process, a pty or a browser), beside the end of that first run; make fails if either
# run failed.
TEST_WORKERS ?= 3  # the second run's worker processes
FIRST_TESTS := tests/nav/test_kernels.py tests/docs/test_docs.py::test_the_site_builds_without_warnings
NOT_FIRST   := -k 'not (test_kernels and python)' --deselect tests/docs/test_docs.py::test_the_site_builds_without_warnings
test: $(STAMP)
	$(BIN)/ruff check .
	report=$$(mktemp); \
	  OPENSHOE_PURE=1 $(BIN)/python -m pytest -q -p no:cacheprovider $(FIRST_TESTS) > $$report 2>&1 & first=$$!; \
	  $(BIN)/python -c '$(FILL_KERNEL_CACHE)'; \
	  $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist worksteal $(NOT_FIRST); rest=$$?; \
	  wait $$first; first=$$?; \
	  echo "--- the first run (OPENSHOE_PURE=1: $(FIRST_TESTS))"; cat $$report; rm -f $$report; \
	  [ $$rest -eq 0 ] && [ $$first -eq 0 ]

demo: $(STAMP)
	$(BIN)/python -m firmware_sim.app.demo

# docs: the site (guides, results, reference generated from the code) into docs/_build/html
docs: $(STAMP)
	$(BIN)/python -m sphinx -W -j auto -b html docs docs/_build/html

clean:
	rm -rf $(VENV) build dist *.egg-info .pytest_cache .ruff_cache docs/_build docs/reference/api
