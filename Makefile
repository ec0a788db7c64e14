# Two commands: `make demo` installs and runs the demo, `make test` installs and runs the tests.
PYTHON ?= python3
VENV ?= .venv
# the suite runs its test files on three processes, the longest files first
# (tests/conftest.py: LONGEST_FIRST): on 2 cores a third fills the time the others wait for
# servers and child processes (the suite's CPU is about 1,150 s; 601 s of wall on three,
# 638-646 s on two: docs/performance.md, "Three test processes on two cores")
TEST_WORKERS ?= 3
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# pip byte-compiles what it installs on one core (about 50 of a 76-s install); the same
# compilation on every core instead. A file that does not compile is passed over, as pip
# passes it over (torch ships one for Python 3.12 only); its module compiles when imported.
export COMPILE_ON_EVERY_CORE := import compileall, sysconfig; \
compileall.compile_dir(sysconfig.get_paths()["purelib"], quiet=2, workers=0)

.PHONY: install demo test clean

install: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet --no-compile -c constraints.txt -e '.[pipeline,test]'
	$(BIN)/python -c "$$COMPILE_ON_EVERY_CORE"
	touch $(STAMP)

demo: install
	$(BIN)/fleet-health demo

test: install
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=25

clean:
	rm -rf $(VENV) .pytest_cache
