# `make demo` and `make test` bootstrap everything on a fresh machine:
# libusb-1.0 (open3d needs it), a .venv, and the package installed editable with its test extra.
# A second run skips what is done.

PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
OUT ?= out
DOCS_OUT ?= docs/_build/html

.PHONY: demo test setup clean syslibs models experiments benchmark docs

setup: syslibs $(STAMP)

syslibs:
	@bash scripts/ensure_syslibs.sh

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(not (3, 11) <= sys.version_info[:2] <= (3, 13))' || { echo "error: $(PYTHON) is not a runnable Python 3.11, 3.12 or 3.13, which manta_drake needs (choose one with PYTHON=..., e.g. make test PYTHON=python3.12)" >&2; exit 1; }
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "installing manta_drake and its pinned dependencies into $(VENV) ..."
	@$(PY) -m pip install --quiet --disable-pip-version-check -e ".[test]" 2>&1 | grep -v "is ignored: it is neither" || true
	@$(PY) -c "import pydrake, open3d, manta_drake" || { echo "error: the install into $(VENV) failed (see above)" >&2; exit 1; }
	@touch $(STAMP)

demo: setup
	$(PY) diagrams/three_behaviors.py --out $(OUT)/three_behaviors

test: setup
	$(PY) -m pytest -q

experiments: setup
	$(PY) diagrams/locomotion.py --out $(OUT)/locomotion
	$(PY) diagrams/two_behaviors.py --out $(OUT)/two_behaviors
	$(PY) diagrams/three_behaviors.py --out $(OUT)/three_behaviors
	$(PY) diagrams/float_sink.py --out $(OUT)/float_sink

benchmark: setup
	$(PY) scripts/benchmark.py
	$(PY) scripts/benchmark_hydro.py
	$(PY) scripts/benchmark_vision.py

models: setup
	$(PY) scripts/generate_models.py

# The API reference (Sphinx, docs/conf.py, sources docs/api/): warnings are errors; -E
# rereads every docstring (Sphinx cannot see that a docstring changed).
docs: setup
	$(PY) -m sphinx -b html -E -W --keep-going -q -d docs/_build/doctrees docs $(DOCS_OUT)
	@echo "API reference: $(DOCS_OUT)/index.html"

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .hypothesis build dist *.egg-info docs/_build
