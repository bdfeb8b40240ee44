# The two commands: `make report` and `make test`. Both build .venv from the machine's python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: report test test-slow clean

$(STAMP): pyproject.toml examples/plugin_solver/pyproject.toml examples/plugin_solver/flexmbd_example_solver.py
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e .
	$(BIN)/python -m pip install --quiet ./examples/plugin_solver   # the example solver plug-in (docs/plugins.md)
	touch $(STAMP)

report: $(STAMP)
	$(BIN)/flexmbd report --out reports

test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadfile   # one test file per core at a time (pytest-xdist)

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

clean:
	rm -rf $(VENV) results reports/*.md reports/*.html reports/results
