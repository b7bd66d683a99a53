# The two set-up commands of the README: `make demo` and `make test`.
# Each creates .venv and installs what it needs; nothing else is assumed.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
DEMO_CASE ?= examples/ciren/100237
DEMO_N ?= 200

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.installed-base: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	# an editable install compiles nothing, and where PYTHONDONTWRITEBYTECODE is set every command would compile
	# crashscene's sources again at start-up (0.1-0.2 s CPU): compile them once, as installing a wheel does
	$(BIN)/python -m compileall -q src
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	# ASAM's OpenDRIVE checker pins numpy<2, which pyarrow refuses; it runs on numpy 2 (its needs are in the extra)
	$(BIN)/python -m pip install -q --no-deps 'asam-qc-opendrive>=1.0,<2'
	$(BIN)/python -m compileall -q src
	touch $@ $(VENV)/.installed-base

.PHONY: demo test bench clean
# One bundled CIREN case through the whole pipeline, offline (rules extractor, embedded simulator), no API key:
# 100237, V2 fails to yield at a 4-leg intersection and strikes the right side of V1 (re-enacted, then the ADS drives V1).
demo: $(VENV)/.installed-base
	rm -rf out/demo
	$(BIN)/crashscene run $(DEMO_CASE) -n $(DEMO_N) --out out/demo
	@echo "open out/demo/report.html"

test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -q

clean:
	rm -rf $(VENV) out
