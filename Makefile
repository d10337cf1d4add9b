# The two commands a user needs are `make demo` and `make test`; both set up whatever is missing first.
SHELL := /bin/bash
.DEFAULT_GOAL := help
ENV := source ./env.sh &&

.PHONY: help setup gate demo test bench stress shell clean

help:
	@echo "make demo   set up (if needed), then run the demo: doctor, the three devices, a recorded bag"
	@echo "make test   set up (if needed), then run the whole test suite"
	@echo "make bench  set up (if needed), then run the benchmarks (table on stdout, plots in bench/results)"
	@echo "make stress Ctrl-C at 20 random moments of each long command's and own-main node's life, under load; 20 launches joining the lockstep; 10 PLC-scene starts"
	@echo "make gate   only the lint and type gate (ruff, mypy), which make test runs first"
	@echo "make setup  only the idempotent setup (.venv, pinned ROS 2 Jazzy wheels, colcon build)"
	@echo "make shell  a bash shell inside the environment (same as 'source env.sh')"

setup:
	@bash tools/setup.sh

demo: setup
	@$(ENV) python tools/demo.py

gate: setup
	@$(ENV) bash tools/gate.sh

# Workers of `make test` (pytest-xdist): each takes a whole test module at a time, so a module's shared
# scene is launched once; TEST_WORKERS=0 runs the suite in this one process.
TEST_WORKERS ?= 2

test: setup gate
	@$(ENV) python -m pytest -n $(TEST_WORKERS) --dist loadfile

bench: setup
	@if [ -f requirements-bench.txt ]; then .venv/bin/python -m pip install --quiet -r requirements-bench.txt; fi
	@$(ENV) python bench/run.py $(BENCH_ARGS)

stress: setup
	@$(ENV) FEEDER_STOP_MOMENTS=20 python -m pytest tests/foundation/test_stop_signals_ros.py
	@$(ENV) FEEDER_JOIN_LAUNCHES=20 python -m pytest tests/cell/test_lockstep_ros.py -k reaches_its_first_quantum
	@$(ENV) FEEDER_OPCUA_STARTS=10 python -m pytest tests/cell/test_opcua_startup_ros.py

shell: setup
	@bash --rcfile <(echo 'source ~/.bashrc 2>/dev/null; source ./env.sh; PS1="(feeder) $$PS1"')

clean:
	rm -rf ros_ws/build ros_ws/install ros_ws/log ros_ws/build.log bench/results
