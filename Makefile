# `make demo` and `make test` bootstrap everything on a fresh machine:
# libusb-1.0 (open3d needs it), a .venv, and the package installed editable with its test extra.
# A second run skips what is done.

PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
OUT ?= out
DOCS_OUT ?= docs/_build/html

.PHONY: demo test setup clean syslibs models experiments benchmark docs FORCE

setup: syslibs $(STAMP)

syslibs:
	@bash scripts/ensure_syslibs.sh

# The stamp holds the venv's Python version; the script skips what is done, and makes the
# venv anew for another PYTHON.
$(STAMP): FORCE
	@bash scripts/bootstrap_venv.sh $(PYTHON) $(VENV)

FORCE:

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
