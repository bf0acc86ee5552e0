# Two entry points: `make demo` (paper §3 on the embedded OP2) and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench slow docs clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/sescid demo --out-dir demo_out

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks examples tools
	$(VENV)/bin/ruff format --check src tests benchmarks examples tools
	$(VENV)/bin/mypy src/sescid

test: lint
	$(PY) -m pytest -q -n auto

slow: $(STAMP)
	$(PY) -m pytest -q -n auto -m slow

docs: $(STAMP)
	$(PY) tools/readme_numbers.py

bench: $(STAMP)
	$(PY) benchmarks/bench_commands.py
	$(PY) benchmarks/bench_regressor.py
	$(PY) benchmarks/bench_poses.py
	$(PY) benchmarks/bench_consistent.py

clean:
	rm -rf $(VENV) demo_out .pytest_cache .ruff_cache
