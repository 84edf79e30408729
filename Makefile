# The two commands a newcomer runs: `make demo` and `make test`.
# Both create .venv, install torch==2.13.0 first (so pip never pulls a CUDA build),
# then the project, and run.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.tendon-id-installed

.PHONY: demo test test-all lint docs bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e ".[test,docs,progress,posterior,export]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/tendon-id demo --out out

# One worker per core (pytest-xdist); a file's tests share a worker, so module fixtures are built once.
test: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow" -n auto --dist loadfile

# Ruff lint and format check (settings in pyproject.toml); `ruff format .` fixes the format.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

test-all: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadfile

docs: $(STAMP)
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

bench: $(STAMP)
	$(BIN)/python perf/bench_simulator.py

clean:
	rm -rf $(VENV) out docs/_build docs/auto_examples
