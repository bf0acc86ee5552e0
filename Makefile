# Two entry points: `make demo` (paper §3 on the embedded OP2) and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CORE   := $(VENV)/.installed-core

LOCK   := requirements-dev.lock

.PHONY: demo test lint bench slow docs clean lock

# the development environment: the lock file's exact versions (pyproject.toml keeps ranges)
$(STAMP): pyproject.toml $(LOCK)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]' -c $(LOCK)
	# the tests' helpers importable by the tools' studies (tools/*.py import them as a library)
	$(PY) -c "import pathlib, sys, sysconfig; pathlib.Path(sysconfig.get_paths()['purelib'], \
	    'sescid-test-helpers.pth').write_text(sys.argv[1] + '\\n')" "$(CURDIR)/tests/helpers"
	touch $(STAMP)

# the demo's environment: the core dependencies only (no extras, no test tools), the lock's
# versions; a venv that already holds the development set (it includes the core) is kept as is
$(CORE): pyproject.toml $(LOCK)
	if [ -f $(STAMP) ] && [ $(STAMP) -nt pyproject.toml ] && [ $(STAMP) -nt $(LOCK) ]; then :; else \
	  $(PYTHON) -m venv $(VENV) && \
	  $(PY) -m pip install -q --upgrade pip && \
	  $(PY) -m pip install -q -e . -c $(LOCK); fi
	touch $(CORE)

demo: $(CORE)
	$(VENV)/bin/sescid demo --out-dir demo_out

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks examples tools
	$(VENV)/bin/ruff format --check src tests benchmarks examples tools
	$(VENV)/bin/mypy src/sescid src/_sescid_launch.py

test: lint
	$(PY) -m pytest -q -n auto

slow: $(STAMP)
	$(PY) -m pytest -q -n auto -m slow

docs: $(STAMP)
	$(PY) tools/readme_numbers.py
	$(PY) tools/torques_walkthrough.py

# speed figures, each beside its target and a reference measured in the same run (docs/speed.md)
bench: $(STAMP)
	$(PY) benchmarks/bench_regressor.py
	$(PY) benchmarks/bench_commands.py
	$(PY) benchmarks/bench_poses.py
	$(PY) benchmarks/bench_consistent.py
	$(PY) benchmarks/bench_first_run.py

# refresh the lock file: the newest releases pyproject.toml's ranges allow, in a scratch venv
lock:
	rm -rf .venv-lock
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install -q --upgrade pip
	.venv-lock/bin/python -m pip install -q -e '.[dev]'
	{ sed -n '1,/^[^#]/{/^#/p}' $(LOCK); .venv-lock/bin/python -m pip freeze --exclude-editable; } > $(LOCK).new
	mv $(LOCK).new $(LOCK)
	rm -rf .venv-lock

clean:
	rm -rf $(VENV) .venv-newest .venv-lock demo_out .pytest_cache .ruff_cache
