# The two commands a fresh clone needs:
#   make demo   set up .venv and run the main job (emulated walk tracked through a pty)
#   make test   set up .venv, lint with ruff, run every test, then the per-kernel
#               equivalence tests again with OPENSHOE_PURE=1 (kernels as plain Python)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint setup clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check .

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q
	OPENSHOE_PURE=1 $(BIN)/python -m pytest -q tests/nav/test_kernels.py

demo: $(STAMP)
	$(BIN)/python -m firmware_sim.app.demo

clean:
	rm -rf $(VENV) build dist *.egg-info .pytest_cache .ruff_cache
