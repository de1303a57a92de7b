# Two entry points on a fresh machine (Python 3.11+): `make run` and `make test`.
# Each creates .venv on first use and installs what it needs.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: run test bench bench-quick gui screenshots clean

$(BIN)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	# numba compiles the kernels once per machine: here, not in the first run (benchmarks/first_run.md)
	$(BIN)/python -m ares.jit
	touch $@

# Main job: a full headless photon-transfer scan on the simulated sensor.
run: $(BIN)/.installed
	$(BIN)/ares run scans/photon_transfer.xml

# All tests but the many-seed studies (offscreen Qt; two workers for the two cores).
# compileall: ares is installed editable, so with PYTHONDONTWRITEBYTECODE set (as on CI VMs)
# no process ever caches its bytecode and each of the suite's hundreds of processes (workers,
# `ares` commands, dask workers) compiled the modules it imports again (~0.5 s CPU each);
# compiling once costs ~1 s and only what changed since (benchmarks/suite_time.md).
test: $(BIN)/.installed
	$(BIN)/python -m compileall -q -x "tests/test_" ares tests
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest -n 2 --dist worksteal -q --durations=30 -m "not study"

# The studies over many seeds or cases (tests marked `study`): coverage, bias and sweeps.
bench-quick: $(BIN)/.installed
	QT_QPA_PLATFORM=offscreen $(BIN)/python -m pytest -n 2 -q --durations=30 -m study

bench: $(BIN)/.installed
	$(BIN)/python benchmarks/run_all.py

gui: $(BIN)/.installed
	$(BIN)/ares gui

# The README's screenshots (docs/screenshots/), the window at 1280x800 under Xvfb
# (needs xvfb-run: apt-get install xvfb libxcb-cursor0), offscreen Qt otherwise.
screenshots: $(BIN)/.installed
	if command -v xvfb-run >/dev/null; then xvfb-run -a -s "-screen 0 1280x800x24" $(BIN)/python tools/screenshots.py; \
	else QT_QPA_PLATFORM=offscreen $(BIN)/python tools/screenshots.py; fi

clean:
	rm -rf $(VENV) runs
