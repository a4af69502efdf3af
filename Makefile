# bullet_floor_sim — `make demo` runs the main job, `make test` runs every test.
# Both bootstrap through `make setup` (idempotent).
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
REPO := $(CURDIR)
VENV_PY := $(REPO)/.venv/bin/python
ROSENV := source $(REPO)/.venv/bin/activate && source $(REPO)/.ws/devel/setup.bash &&
WORLD ?= office

.PHONY: setup test unit-test integration-test lint demo bench clean

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
integration-test:
	$(ROSENV) for t in test/integration/*.test; do \
	  echo "== rostest $$t"; rostest --text bullet_floor_sim $$(basename $$t) || exit 1; done

lint:
	$(ROSENV) catkin_lint -q -W2 --strict --pkg bullet_floor_sim

# The simulator on the office world, with rviz when a display is available (headless otherwise);
# the Markov-walker demo replaces it when it lands. Ctrl-C stops it.
demo: setup
	$(ROSENV) roslaunch bullet_floor_sim sim.launch world:=$(WORLD) \
	  rviz:=$$( [ -n "$$DISPLAY" ] && echo true || echo false )

bench: setup
	$(ROSENV) $(VENV_PY) bench/run_all.py

clean:
	rm -rf .ws .venv "$${BFS_WS:-$${XDG_CACHE_HOME:-$$HOME/.cache}/bullet_floor_sim/ws-$$(printf %s "$(REPO)" | sha1sum | cut -c1-8)}"
