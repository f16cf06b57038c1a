# One command sets everything up and runs the job: `make demo` (the package alone); the
# tests: `make test` (the package and its development tools)
# (the inner loop: `make test-fast`, the suite without its slow and heavy tests).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# Debian packages a full `make test` needs (install as root: `make system-deps`); without
# them the tests that need them skip, and the summary lists what was missing.
#   chromium: the meshcat view tests; gcc-avr avr-libc arduino-core-avr: the firmware
#   build; simavr libsimavr-dev libelf-dev gcc libc6-dev: the firmware run in simavr;
#   libegl1 libegl-mesa0 libgl1-mesa-dri (libosmesa6 as a fallback): MuJoCo's offscreen
#   rendering on the CPU, the physical twin's camera (MUJOCO_GL=egl)
SYSTEM_DEPS := make gcc libc6-dev chromium gcc-avr avr-libc arduino-core-avr \
               simavr libsimavr-dev libelf-dev \
               libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6

.PHONY: install demo wheel test test-fast soak lint bench urdf firmware preview clean system-deps

# Two stamps: the package alone (what `make demo` needs, no test or analysis tools) and
# the package with its development extras (`make install`, `make test`, `make lint`).
BASE_STAMP := $(VENV)/.installed-base

$(BASE_STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e .
	touch $(BASE_STAMP)

$(STAMP): $(BASE_STAMP)
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

demo: $(BASE_STAMP)
	$(BIN)/mearm sort --config sim

# The wheel (dist/mearm-VERSION-py3-none-any.whl): the package, its configs, arm
# descriptions, firmware source and the docs' pages; `pip install dist/mearm-*.whl` on
# another machine.
wheel: $(BASE_STAMP)
	$(BIN)/python -m pip wheel -q --no-deps -w dist .
	@ls dist/mearm-*.whl

# The suite runs in JOBS processes (pytest-xdist; JOBS=0: in this one, e.g. for --pdb);
# worksteal hands a worker that ran out of tests some of another's. `make test` runs one
# worker more than cores: about a seventh of a worker's time there is spent waiting (child
# processes starting, boards answering, signals timed), and the extra worker fills it
# (2 cores, back to back: 5 min 30 s with 2 workers, 4 min 44 s with 3; 4 workers were
# slower than 3). `make test-fast` has little to wait for and runs one per core (54 s with
# 2 workers, 57 s with 3).
JOBS ?= $(shell echo $$(( $$(nproc) + 1 )))
FAST_JOBS ?= $(if $(filter command line,$(origin JOBS)),$(JOBS),auto)
# Hundreds of tests run mearm in a child process: with bytecode off (PYTHONDONTWRITEBYTECODE)
# each one compiles the package again (user + sys CPU of the whole suite 7.7 -> 7.1 min on a
# warm cache, 2 cores). Bytecode goes beside the sources, where pip put the dependencies':
# a PYTHONPYCACHEPREFIX would hide those, and each worker of a fresh clone compiled them
# all again (collecting the suite: 13.2 s of CPU a worker, 9.9 s without, 3.9 s warm).
BYTECODE := env -u PYTHONDONTWRITEBYTECODE -u PYTHONPYCACHEPREFIX $(BIN)/python
PYTEST := $(BYTECODE) -m pytest -q --dist worksteal
# A fresh clone's first collection rewrites every test module's asserts (pytest keeps the
# result beside them in __pycache__), and each xdist worker did it at once for the whole
# suite: 6 s of CPU a worker, and each compiled the package racing the others. Before the
# workers start, two collections of half the modules each write that cache and one
# compileall the package's bytecode (3 workers collecting a fresh clone, 2 cores: 20 s
# wall and 27 s of CPU; after the warm-up, 6 s and 11 s, the two halves 6 s and 12 s).
# Its output is dropped: the suite's own collection reports what fails to collect.
WARM := ( $(BYTECODE) -m compileall -q mearm \
          & $(BYTECODE) -m pytest -q --collect-only -p no:xdist -p no:cacheprovider \
            --ignore-glob='*/test_[a-l]*' \
          & $(BYTECODE) -m pytest -q --collect-only -p no:xdist -p no:cacheprovider \
            --ignore-glob='*/test_[m-z]*' \
          ; wait ) >/dev/null 2>&1 || true

# It ends with its 15 slowest tests and the 15 test files that used the most CPU
# (--cpu-top, tests/conftest.py: on 2 cores the suite's wall time follows its CPU).
test: $(STAMP)
	@$(WARM)
	$(PYTEST) -n $(JOBS) --durations=15 --cpu-top=15

test-fast: $(STAMP)
	@$(WARM)
	$(PYTEST) -n $(FAST_JOBS) -m "not slow and not heavy"

# Long runs in one process (a few minutes; `make test` leaves them out): 300 kinematic and
# 50 twin sorts, the meshcat server with 20 clients for 60 s; memory, files and threads flat;
# IK on 20,000 random targets of the paper arm, 0 stalls (tests/test_ik_stall.py); and
# Ctrl-C at 50 random moments of a sort, each parked (tests/test_interrupt.py).
soak: $(STAMP)
	env -u PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX=$(CURDIR)/$(VENV)/pycache \
	  $(BIN)/python -m pytest -q -s -p no:xdist -m soak tests/test_soak.py tests/test_ik_stall.py \
	  tests/test_interrupt.py

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

system-deps:
	apt-get update -qq
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	  $(SYSTEM_DEPS) >/dev/null

clean:
	rm -rf $(VENV) dist build .pytest_cache .ruff_cache .mypy_cache
