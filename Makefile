# One command sets everything up and runs the job: `make demo`; the tests: `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: install demo test lint bench urdf firmware preview clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m mearm.sort --config configs/sim.yaml

test: $(STAMP)
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check mearm tools tests
	$(BIN)/ruff format --check mearm tools tests
	$(BIN)/mypy mearm

bench: $(STAMP)
	$(BIN)/python tools/bench.py

preview: $(STAMP)
	$(BIN)/python tools/preview.py

urdf: $(STAMP)
	$(BIN)/python tools/dh_to_urdf.py --config configs/lab.yaml

firmware:
	$(MAKE) -C tools/arduino

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .mypy_cache
