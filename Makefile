# casewatch developer entry points. Every target creates the local .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-test
EXTRAS ?= test

.PHONY: test demo bench data lint clean venv warm-up

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS)]"
	$(BIN)/python -m casewatch warm-up
	touch $(STAMP)

venv: $(STAMP)

# Fill numba's cache with every compiled kernel (the install step above runs it too), so the
# first run does not compile for ~40 s; again after pulling changes to the kernels.
warm-up: $(STAMP)
	$(BIN)/python -m casewatch warm-up

# The static checks first (seconds), then the suite (minutes): the house rules in code
# (docs/architecture.md): lint, one format, the layer contract, types of the public modules.
test: lint
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports
	$(BIN)/mypy

demo: $(STAMP)
	$(BIN)/python -m tools.demo

bench: $(STAMP)
	$(BIN)/python -m bench

data: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[test,sim]"
	$(BIN)/python -m examples.sim.build_data

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
