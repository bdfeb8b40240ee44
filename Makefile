# The two commands: `make report` and `make test`. Both build .venv from the machine's python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: report test test-slow convergence clean

$(STAMP): pyproject.toml constraints.txt
	rm -rf $(VENV)                       # exactly the tested set, nothing left from before
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip -c constraints.txt
	$(BIN)/python -m pip install --quiet --no-compile -c constraints.txt -e '.[test]'   # the tested versions (constraints.txt)
	@# byte-code on every core (pip compiles on one), but not of what flexmbd never imports (Exudyn's
	@# OpenGL renderer, the installers, the packages' own test suites); files some packages ship
	@# that do not compile (pip skips them too) set the exit status, so it is not checked
	-@$(BIN)/python -m compileall -q -j 0 -x '/site-packages/(OpenGL|pip|setuptools)/|/tests?/' $(VENV)/lib flexmbd > /dev/null 2>&1
	touch $(STAMP)

report: $(STAMP)
	$(BIN)/flexmbd report --out reports

test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadfile   # one test file per core at a time (pytest-xdist)

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

# The convergence studies drawn on the case pages (cases/convergence/NAME.toml): each run into
# reports/convergence/NAME (its runs kept by key: a rerun runs only what changed) and its table
# stored as cases/convergence/NAME.parquet. STUDIES=NAME ... runs some of them.
STUDIES ?= $(basename $(notdir $(wildcard cases/convergence/*.toml)))
convergence: $(STAMP)
	@for n in $(STUDIES); do \
	  $(BIN)/flexmbd study --file cases/convergence/$$n.toml --out reports/convergence/$$n --allow-large || exit $$?; \
	  cp reports/convergence/$$n/study.parquet cases/convergence/$$n.parquet.tmp && \
	  mv cases/convergence/$$n.parquet.tmp cases/convergence/$$n.parquet || exit $$?; \
	done

clean:
	rm -rf $(VENV) results reports/*.md reports/*.html reports/results
