# Two commands do all the set-up on a fresh machine with Python 3.11 and pip:
#   make run    the chapter's experiment, with its figures, into results/
#   make test   lint + format check + type check + tests
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
RUN_STAMP  := $(VENV)/.stamp-run
TEST_STAMP := $(VENV)/.stamp-test
OUT ?= results

.PHONY: run test lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(RUN_STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install -q -e .
	touch $@

$(TEST_STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install -q -e ".[dev,rl,cluster]"
	touch $@ $(RUN_STAMP)

run: $(RUN_STAMP)
	$(BIN)/striatal simulate --chapter-final --out $(OUT)/chapter-final

lint: $(TEST_STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	$(BIN)/mypy

test: lint
	$(BIN)/pytest -q

clean:
	rm -rf $(VENV) $(OUT)
