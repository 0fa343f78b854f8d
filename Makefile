# Everything runs from the project venv; the stamp re-installs when pyproject.toml changes.
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test bench lint

$(STAMP): pyproject.toml
	test -x $(BIN)/python || python3 -m venv $(VENV)
	$(BIN)/python -m pip install -e '.[dev]'
	touch $@

run: $(STAMP)
	$(BIN)/tandem plan static/scenarios/default.toml --first-branch

test: $(STAMP)
	$(BIN)/pytest -q

bench: $(STAMP)
	$(BIN)/tandem bench

lint: $(STAMP)
	$(BIN)/ruff check planner tests
	$(BIN)/mypy planner
