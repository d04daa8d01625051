# The two commands: `make run` and `make test` (each creates .venv and installs first).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: run test lint bench clean chromium

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	-@$(MAKE) --no-print-directory chromium
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/vdevd serve $(ARGS)

lint: $(STAMP)
	$(VENV)/bin/ruff check vdevd client proto tests bench
	$(VENV)/bin/mypy

test: $(STAMP) lint
	$(PY) -m pytest -q $(PYTEST_ARGS)

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	$(PY) bench/run.py $(ARGS)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache

# the web view's browser test (tests/test_web_browser.py) runs headless Chromium: installed here
# when it is missing and we are root with apt; otherwise (or if apt fails) the test is skipped,
# saying why, and the install goes on
chromium:
	@if [ ! -x /usr/bin/chromium ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "installing chromium (apt) for the web view's browser test"; \
	  (export DEBIAN_FRONTEND=noninteractive; apt-get update -qq && \
	   apt-get install -y -qq --no-install-recommends chromium) >/dev/null 2>&1 || \
	  echo "could not install chromium: tests/test_web_browser.py will be skipped"; \
	fi
