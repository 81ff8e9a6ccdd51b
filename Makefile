# quadcos: `make train` and `make test` work on a machine with nothing but Python 3.11+.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
TRAIN_ARGS ?=

.PHONY: install test test-fast train clean

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv --clear $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test,plots]"
	touch $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

# Everything but the end-to-end tests marked slow (those run in `make test`).
test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

# The paper's flat experiment at CPU scale (see README for how long it takes).
train: $(STAMP)
	$(BIN)/python -m quadcos.train --preset=cpu --terrain=flat --output_dir=runs/flat $(TRAIN_ARGS)

clean:
	rm -rf $(VENV) .jax_cache .pytest_cache
