# Two commands on a fresh machine with Python 3.11+ and make: `make demo`, `make test`.
# Dependencies: pyproject.toml declares compatible ranges; constraints.txt pins the exact
# versions installed here (and in CI).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-browser browser warm lint bench clean

# pip compiles every installed module to bytecode on one core (about 48 s of the install);
# compileall does it on two.  Then the numba kernels: each is compiled on first use and cached
# beside its source, about 55 s for `fused` alone, so they are compiled here, once, in two
# processes (sideslip.warmup): the first estimate, `make demo` and the test workers start warm.
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet --no-compile -c constraints.txt -e ".[all]"
	$(BIN)/python -m compileall -q -j 2 $$($(BIN)/python -c "import sysconfig; print(sysconfig.get_path('purelib'))") > /dev/null \
		|| echo "note: some modules are left for Python to compile on import"
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

# the kernels again after a source change.  numba keys each cached kernel on its own file
# only: a kernel that calls a changed kernel of another module (fused_measurements calling
# models.axle_force) keeps its stale machine code, so every cache is dropped first
warm: $(STAMP)
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete
	$(BIN)/python -m sideslip.warmup --jobs 2

# the install and the browser side by side (pip and apt each mostly wait on one core)
test:
	$(MAKE) --no-print-directory -j 2 $(STAMP) browser
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
