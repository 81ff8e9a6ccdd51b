# quadcos: `make train` and `make test` work on a machine with nothing but Python 3.11+.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
TRAIN_ARGS ?=

.PHONY: install test test-fast train notebooks docs docs-build clean

install: $(STAMP)

# uv (from PyPI, into the venv) installs the packages, unpacking them side by side, in a fraction
# of pip's time; where uv cannot be had, Python's own pip does it. Neither byte-compiles every
# installed file: imports compile what they use.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv --clear $(VENV)
	($(BIN)/python -m pip install -q uv && $(BIN)/uv pip install -q --python $(BIN)/python \
		-e ".[test,plots]") || $(BIN)/python -m pip install -q --no-compile -e ".[test,plots]"
	touch $(STAMP)

# Two pytest workers (pytest-xdist), a test file each at a time: the suite is compile-bound and
# XLA compiles one program on one core. Python's bytecode goes to .venv/pycache, written by the
# first process that imports a module and read by the others (workers, CLI subprocesses, notebook
# kernels), also where PYTHONDONTWRITEBYTECODE is set: an import of quadcos takes 2 s, not 5.
PYTEST := PYTHONDONTWRITEBYTECODE= PYTHONPYCACHEPREFIX=$(CURDIR)/$(VENV)/pycache \
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

test: $(STAMP)
	$(PYTEST)

# Everything but the end-to-end tests marked slow (those run in `make test`).
test-fast: $(STAMP)
	$(PYTEST) -m "not slow"

# The paper's flat experiment at CPU scale (see README for how long it takes). A second
# `make train` writes runs/flat-2 (then -3, ...) and says so; the run directory ends up on stdout.
train: $(STAMP)
	$(BIN)/python -m quadcos.train --preset=cpu --terrain=flat --output_dir=runs/flat --numbered $(TRAIN_ARGS)

# Jupyter (the `notebooks` extra) into .venv, then JupyterLab on notebooks/ (it prints the URL).
notebooks: $(VENV)/.notebooks-stamp
	$(BIN)/jupyter lab notebooks

$(VENV)/.notebooks-stamp: $(STAMP)
	$(BIN)/python -m pip install -q -e ".[notebooks,plots,video]"
	touch $@

# The documentation (the `docs` extra into .venv): `make docs` serves docs/ at http://127.0.0.1:8000
# while you edit; `make docs-build` builds it into site/ and fails on any broken link.
docs: $(VENV)/.docs-stamp
	$(BIN)/python -m mkdocs serve

docs-build: $(VENV)/.docs-stamp
	$(BIN)/python -m mkdocs build --strict -d site

$(VENV)/.docs-stamp: $(STAMP)
	$(BIN)/python -m pip install -q -e ".[docs]"
	touch $@

# Keeps runs/: trained runs are results, not build products.
clean:
	rm -rf $(VENV) .jax_cache .pytest_cache
	@if [ -d runs ]; then echo "make clean: kept runs/ (your trained runs); delete it yourself with rm -rf runs" >&2; fi
