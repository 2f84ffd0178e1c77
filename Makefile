# Two commands do all set-up on a fresh Debian/Ubuntu machine with Python 3.10+:
#   make demo   - create .venv, install, run the default scene headless (out/<scene>/)
#   make test   - create .venv, install, lint, run the test suite
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup demo test test-slow lint bench notebooks system-deps clean

$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

system-deps:
	@bash tools/system_deps.sh

setup: $(STAMP) system-deps

demo: setup
	$(PY) main.py

lint: $(STAMP)
	$(PY) -m ruff check .

test: setup lint
	$(PY) -m pytest -q

test-slow: setup
	$(PY) -m pytest -q -m slow

bench: setup
	$(PY) main.py bench

notebooks: setup
	$(PY) tools/notebooks.py run

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
