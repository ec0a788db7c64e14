# Two commands: `make demo` installs and runs the demo, `make test` installs and runs the tests.
PYTHON ?= python3
VENV ?= .venv
# the suite runs its test files on two processes (2 cores: 6.5 min instead of 10.5), the
# longest files first (tests/conftest.py: LONGEST_FIRST)
TEST_WORKERS ?= 2
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install demo test clean

install: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[pipeline,test]'
	touch $(STAMP)

demo: install
	$(BIN)/fleet-health demo

test: install
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=25

clean:
	rm -rf $(VENV) .pytest_cache
