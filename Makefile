# hyperqn front door. On a fresh Debian 12 (as root):
#   make run    install dependencies, build, run the default deck on 2 MPI ranks
#   make test   install dependencies, build, run the whole test suite (ctest)
BUILD   ?= build
NP      ?= 2
DECK    ?= input/bar.yaml
MPIEXEC ?= mpiexec
PYTHON  ?= /usr/bin/python3
JOBS    ?= $(shell nproc)
ARGS    ?=
CONTACT_ARGS ?=

# Open MPI refuses to run as root without these; harmless for other users.
export OMPI_ALLOW_RUN_AS_ROOT = 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM = 1
export OMPI_MCA_rmaps_base_oversubscribe = 1
# The Python tools (bench, study, stability) import the package postprocess/hyperqn_tools.
export PYTHONPATH := $(CURDIR)/postprocess$(if $(PYTHONPATH),:$(PYTHONPATH))

STUDY_DECKS ?= $(wildcard input/study/*.yaml)
STUDY_RANKS ?= 1 2
STABILITY_DECKS ?= $(wildcard input/stability/*.yaml)
STABILITY_NP    ?= 1
SWEEP ?= input/sweeps/bar_stiffness.yaml

.PHONY: all deps build run test bench study stability sweep fuzz faults clean

all: build

deps:
	bash scripts/install-deps.sh

build: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DHYPERQN_PYTHON=$(PYTHON)
	cmake --build $(BUILD) -j $(JOBS)

run: build
	$(MPIEXEC) -n $(NP) $(BUILD)/hyperqn $(DECK) $(ARGS)

# ctest -j: tests run side by side as far as the cores allow; each declares the processors it
# uses (PROCESSORS in tests/CMakeLists.txt: the MPI tests their rank count; the end-to-end tests 1,
# as most of their runs are of one rank, and 2 for one that times its runs, which then runs alone).
test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

bench: build
	$(PYTHON) bench/bench.py $(ARGS)
	$(PYTHON) bench/contact.py $(CONTACT_ARGS)

# Every deck in input/study/ at 1 and 2 ranks, then plots and tables in output/study/.
study: build
	@set -e; dirs=""; for deck in $(STUDY_DECKS); do for n in $(STUDY_RANKS); do \
	  out=output/study/$$(basename $$deck .yaml)-np$$n; \
	  echo "== $$deck on $$n rank(s) -> $$out"; \
	  $(MPIEXEC) -n $$n $(BUILD)/hyperqn study $$deck -o $$out $(ARGS); \
	  dirs="$$dirs $$out"; done; done; \
	$(PYTHON) -m hyperqn_tools.study_report $$dirs --out output/study/report.md

# Every deck in input/stability/ with every solver, judged: output/stability/stability.md,
# stability.csv and PNGs (see docs/stability.md).
stability: build
	$(PYTHON) -m hyperqn_tools.stability $(STABILITY_DECKS) --out output/stability --bin $(BUILD)/hyperqn \
	  --np $(STABILITY_NP) --mpiexec $(MPIEXEC) $(ARGS)

# A sweep file's cases, each on NP ranks, -> output/sweep/<sweep name>/<case>/, sweep.csv and
# sweep.md (see docs/sweeps.md). ARGS="--out DIR", "--case K", "--table-only", "--list".
sweep: build
	$(PYTHON) -m hyperqn_tools.sweep $(SWEEP) --np $(NP) --bin $(BUILD)/hyperqn --mpiexec $(MPIEXEC) $(ARGS)

# The input fuzzer: 1000 mutated decks, meshes and option sets (see scripts/fuzz.py) -> output/fuzz/.
fuzz: build
	$(PYTHON) scripts/fuzz.py --cases 1000 --bin $(BUILD)/hyperqn $(ARGS)

# Fault injection: 240 trials of kills, full disks, unwritable places, damaged checkpoints, reused
# directories and requeue loops at 1 and 2 ranks (see scripts/faults.py) -> output/faults/.
faults: build
	$(PYTHON) scripts/faults.py --trials 240 --bin $(BUILD)/hyperqn $(ARGS)

clean:
	rm -rf $(BUILD)
