# Everything runs in .venv at the repository root, created on first use.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: install test demo bench lint typecheck clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	# torch first, from the CPU build on these machines; the project's torch range admits it.
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

# lint and type check first: a finding stops the run before the (long) test suite; the suite on two processes
# (pytest-xdist), a test file's tests in one (its module fixtures made once)
test: lint typecheck
	$(PY) -m pytest -q -n 2 --dist loadfile

demo: $(STAMP)
	experiments/demo.sh demo_output

bench: $(STAMP)
	$(PY) benchmarks/bench_env.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_roads.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_multi_ego.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_one_ego.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_record.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_evaluate.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_train.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_rail_egos.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_import.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_replay.py --out docs/benchmarks.md
	$(PY) benchmarks/bench_acceleration.py --out docs/benchmarks.md
	# frames, MP4s and (with a display, e.g. under xvfb-run) a sumo-gui episode
	$(PY) benchmarks/bench_render.py --out docs/benchmarks.md
	# highway-env (and pygame-ce) only for the comparison; it accepts the project's gymnasium 1.x. If it cannot be
	# installed ('-': go on), bench_compare says so in its section.
	-$(PY) -m pip install --quiet 'highway-env>=1.10,<2'
	$(PY) benchmarks/bench_compare.py --out docs/benchmarks.md

lint: $(STAMP)
	$(VENV)/bin/ruff check sumo_rail cli tests benchmarks experiments

# mypy on sumo_rail and cli, as [tool.mypy] in pyproject.toml configures it
typecheck: $(STAMP)
	$(PY) -m mypy

clean:
	rm -rf $(VENV) build *.egg-info
