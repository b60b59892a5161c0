# Two commands on a fresh machine with Python 3.11+ and make: `make demo`, `make test`.
# Dependencies: pyproject.toml declares compatible ranges; constraints.txt pins the exact
# versions installed here (and in CI).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-browser browser warm lint bench clean

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[all]"
	$(BIN)/python -m sideslip.warmup --jobs 2
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/sideslip demo

# Headless Chromium for the report's browser tests (Debian package).  As root (CI) it is
# installed when missing; otherwise a note is printed and the browser tests skip.
browser:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = "0" ]; then \
		(apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium) || \
		echo "note: could not install chromium: the browser tests will skip"; \
	else \
		echo "note: chromium is not installed and this is not root: the browser tests will skip" \
		     "(sudo apt-get install chromium, then make test-browser)"; \
	fi

# numba compiles each kernel on first use and caches it beside its source; two cold test
# workers would each compile the same kernels (fresh clone: pytest 9:21 cold, 5:40 warm), so
# they are compiled first, once, in two processes (sideslip.warmup; a few seconds when warm)
warm: $(STAMP)
	$(BIN)/python -m sideslip.warmup --jobs 2

test: $(STAMP) browser warm
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

test-browser: $(STAMP)
	@command -v chromium >/dev/null 2>&1 || \
		(apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium)
	$(BIN)/python -m pytest -q -p no:xdist -m browser tests/report

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/sideslip bench

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache build src/*.egg-info
