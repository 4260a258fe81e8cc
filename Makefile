# `make demo` and `make test` bootstrap everything on a fresh machine:
# libusb-1.0 (open3d needs it), a .venv, and the package installed editable with its test extra.
# A second run skips what is done.

PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
OUT ?= out
DOCS_OUT ?= docs/_build/html
# Sphinx's cache (doctrees) beside the HTML: docs/_build/doctrees by default, and outside the
# checkout when DOCS_OUT is (DOCS_OUT=/tmp/site/html caches in /tmp/site/doctrees).
DOCS_CACHE ?= $(dir $(abspath $(DOCS_OUT)))doctrees

.PHONY: demo test lint setup clean syslibs models experiments benchmark docs cfd FORCE

setup: syslibs $(STAMP)

syslibs:
	@bash scripts/ensure_debian.sh libusb

# The stamp holds the venv's Python version; the script skips what is done, and makes the
# venv anew for another PYTHON.
$(STAMP): FORCE
	@bash scripts/bootstrap_venv.sh $(PYTHON) $(VENV)

FORCE:

demo: setup
	$(PY) diagrams/three_behaviors.py --out $(OUT)/three_behaviors

# ruff's lint and format check of the whole checkout, then mypy on its scope: both configured in pyproject.toml
# ([tool.ruff], [tool.mypy]), both the venv's pinned versions (the test extra). The same
# checks run before each commit with .pre-commit-config.yaml.
lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

# The lint first: a finding stops the run before the (long) suite.
# scripts/ensure_debian.sh openfoam: Debian's OpenFOAM (about 80 s the first time, quiet once
# installed) for the CFD study's one slow end-to-end test.
test: setup lint
	@bash scripts/ensure_debian.sh openfoam
	$(PY) -m pytest -q --durations=25

experiments: setup
	$(PY) diagrams/locomotion.py --out $(OUT)/locomotion
	$(PY) diagrams/two_behaviors.py --out $(OUT)/two_behaviors
	$(PY) diagrams/three_behaviors.py --out $(OUT)/three_behaviors
	$(PY) diagrams/float_sink.py --out $(OUT)/float_sink

benchmark: setup
	$(PY) scripts/benchmark.py
	$(PY) scripts/benchmark_hydro.py
	$(PY) scripts/benchmark_vision.py

# The CFD study of the hull's damping (docs/cfd.md): every case under CFD_OUT (a rerun
# skips the finished ones), the samples into models/cfd/.
CFD_OUT ?= $(OUT)/cfd
CFD_WORKERS ?= 2
cfd: setup
	@bash scripts/ensure_debian.sh openfoam
	$(PY) -m manta_drake.cli study cfd --runs $(CFD_OUT) --cases all --workers $(CFD_WORKERS)

models: setup
	$(PY) scripts/generate_models.py

# The API reference (Sphinx, docs/conf.py, sources docs/api/): warnings are errors; -E
# rereads every docstring (Sphinx cannot see that a docstring changed). With DOCS_OUT outside
# the checkout a build writes nothing into it (docs/conf.py writes no bytecode either).
docs: setup
	$(PY) -m sphinx -b html -E -W --keep-going -q -d $(DOCS_CACHE) docs $(DOCS_OUT)
	@echo "API reference: $(DOCS_OUT)/index.html"

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .hypothesis .mypy_cache .ruff_cache build dist *.egg-info \
		docs/_build
