# bullet_floor_sim — `make demo` runs the main job, `make test` runs every test.
# Both bootstrap through `make setup` (idempotent).
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
REPO := $(CURDIR)
VENV_PY := $(REPO)/.venv/bin/python
ROSENV := source $(REPO)/.venv/bin/activate && source $(REPO)/.ws/devel/setup.bash &&
WORLD ?= office

.PHONY: setup test unit-test integration-test lint demo bench eval demo-legs corpus ppo-smoke clean

setup:
	bash tools/setup.sh

# Every test: lint, unit tests (no roscore), integration tests (rostest).
test: setup
	$(MAKE) --no-print-directory lint
	$(MAKE) --no-print-directory unit-test
	$(MAKE) --no-print-directory integration-test

unit-test:
	$(ROSENV) $(VENV_PY) -m pytest -q -p no:cacheprovider test/unit

# rostest starts its own master (port 22422), so a running roscore does not interfere.
# rostest --text exits 0 even when a test fails ("overall test result is not accurate"), so
# the summary it prints decides: every file must report RESULT: SUCCESS and none a FAIL.
integration-test:
	$(ROSENV) log=$$(mktemp); trap 'rm -f "$$log"' EXIT; \
	for t in test/integration/*.test; do \
	  echo "== rostest $$t"; rostest --text bullet_floor_sim $$(basename $$t) 2>&1 | tee "$$log"; \
	  if ! grep -q "RESULT: SUCCESS" "$$log" || grep -q "RESULT: FAIL" "$$log"; then \
	    echo "== FAILED: $$t"; exit 1; fi; done

lint:
	$(ROSENV) catkin_lint -q -W2 --strict --pkg bullet_floor_sim
	$(VENV_PY) -m ruff check --quiet .
	cd $(REPO) && if $(VENV_PY) -c 'import sys; sys.exit(sys.version_info < (3, 10))'; then \
	  $(VENV_PY) -m mypy; else echo "== mypy skipped: mypy 2 needs Python >= 3.10"; fi

# The main job: demo.launch on the office world (walker, observer, ROIs, trajectories), with
# rviz when a display is available (headless otherwise). Ctrl-C stops it.
# make demo NAV=builtin RECORD=true RTF=2 passes those launch args.
NAV ?= auto
RECORD ?= false
RTF ?= 1.0
demo: setup
	$(ROSENV) roslaunch bullet_floor_sim demo.launch world:=$(WORLD) nav:=$(NAV) \
	  record:=$(RECORD) rtf:=$(RTF) rviz:=$$( [ -n "$$DISPLAY" ] && echo true || echo false )

bench: setup
	$(ROSENV) $(VENV_PY) bench/run_all.py

# The corpus of real buildings (worlds/corpus.yaml): download each source, check it, build
# a world under $BFS_CORPUS (~/.cache/bullet_floor_sim/corpus). Offline: FROM=DIR with the files.
FROM ?=
corpus: setup
	$(ROSENV) $(VENV_PY) tools/corpus.py $(if $(FROM),--from $(FROM))

# The destination-prediction study on every shipped world and every corpus world built: one table,
# an EVAL line per world and seed
# (LEGS legs each, seeds SEED, e.g. SEED="1 2 3"; 200 legs take 3-10 min a world). WORKERS tasks
# at a time (default: the cores; 1: one after the other, the rtf side by side); RAY=ADDRESS runs
# them on a Ray cluster (local, auto, ray://HOST:10001); RESULTS=URI also stores each row there
# (mongodb://HOST:PORT/ or a directory). docs/evaluation.md, "Studies on many cores".
LEGS ?= 200
SEED ?= 1
WORKERS ?=
RAY ?=
RESULTS ?=
# WORLDS: names under worlds/ or world.yaml paths (default: every shipped and corpus world)
WORLDS ?=
eval: setup
	$(ROSENV) $(VENV_PY) bench/eval_worlds.py --legs $(LEGS) --seed $(SEED) \
	  $(if $(WORLDS),--worlds $(WORLDS)) $(if $(WORKERS),--workers $(WORKERS)) $(if $(RAY),--ray $(RAY)) $(if $(RESULTS),--results $(RESULTS))

# Does learning happen on the Gymnasium environment? A short stable-baselines3 PPO run against
# a random policy on held-out seeds (bench/ppo_smoke.py; installs requirements/rl.txt, torch
# among them, into .venv first: about 1 GB).
ppo-smoke: setup
	$(VENV_PY) -m pip install -q -r requirements/rl.txt -c requirements/constraints.txt
	$(ROSENV) $(VENV_PY) bench/ppo_smoke.py

# The full ROS demo (demo.launch, embedded navigation, observer following) on every shipped
# world, headless at rtf RTF (0 = flat out), until LEGS walker legs have ended: legs given up,
# the real-time factor held, what the simulator waited for, each node's CPU and memory
# (bench/demo_legs.py); PEOPLE people walking too (-1: as each world file says); WORLDS as
# for eval.
PEOPLE ?= -1
demo-legs: setup
	$(ROSENV) $(VENV_PY) bench/demo_legs.py --legs $(LEGS) --seed $(SEED) --rtf $(RTF) --people $(PEOPLE) \
	  $(if $(WORLDS),--worlds $(WORLDS))

clean:
	rm -rf .ws .venv "$${BFS_WS:-$${XDG_CACHE_HOME:-$$HOME/.cache}/bullet_floor_sim/ws-$$(printf %s "$(REPO)" | sha1sum | cut -c1-8)}"
