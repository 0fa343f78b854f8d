# Everything runs from the project venv; the stamp re-installs when pyproject.toml changes.
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test bench lint browser

# The browser tests drive Debian's chromium; install it once if it is missing.
browser:
	test -x /usr/bin/chromium || { \
		SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
		$$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq chromium; }

$(STAMP): pyproject.toml
	test -x $(BIN)/python || python3 -m venv $(VENV)
	$(BIN)/python -m pip install -e '.[dev]'
	touch $@

run: $(STAMP)
	$(BIN)/tandem dashboard --scenario static/scenarios/default.toml

test: $(STAMP) browser
	$(BIN)/pytest -q

bench: $(STAMP) browser
	$(BIN)/tandem bench
	$(BIN)/python -m app.dashboard.bench

lint: $(STAMP)
	$(BIN)/ruff check planner app tests
	$(BIN)/mypy planner app
