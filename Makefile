# frictionid: two commands for a newcomer — `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.frictionid-setup
IFACE_STAMP := $(VENV)/.frictionid-interfaces

.PHONY: setup demo demo-loop demo-fleet test test-long test-core bags bench-optim clean

setup: $(STAMP) $(IFACE_STAMP)

$(STAMP): requirements.txt constraints.txt frictionid_core/pyproject.toml frictionid_ros/setup.py
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q -r requirements.txt -c constraints.txt
	$(PIP) install -q --no-deps -e frictionid_core
	$(PIP) install -q --no-deps -e frictionid_ros --config-settings editable_mode=compat
	touch $@

$(IFACE_STAMP): $(STAMP) $(shell find ros2_ws/src/frictionid_interfaces/ -type f 2>/dev/null)
	@if [ -d ros2_ws/src/frictionid_interfaces ]; then \
	  VIRTUAL_ENV=$(abspath $(VENV)) AMENT_PREFIX_PATH=$(abspath $(VENV)) PATH=$(abspath $(VENV))/bin:$$PATH \
	    tools/build_interfaces.sh $(abspath $(VENV)); fi
	touch $@

demo: setup
	$(VENV)/bin/frictionid identify bags/emps_estimation --system emps --friction coulomb --solver ls --json demo_result.json
	$(VENV)/bin/frictionid validate bags/emps_validation --params demo_result.json --json demo_validation.json

# A small synthetic fleet (4 robots × 16 daily logs, one Coulomb drift, one broken log) identified on 2
# local workers, with its drift alarm and dashboard (demo_fleet/out/index.html; ~1 min).
demo-fleet: setup
	rm -rf demo_fleet
	$(PY) tools/synth_fleet.py demo_fleet/data --robots 4 --logs 16 --drift 2:1:11:0.25:3 --broken 1:5:truncated
	$(VENV)/bin/frictionid fleet demo_fleet/data/fleet.yaml --out demo_fleet/out --workers 2

# Friction compensation in the loop: simulated arm, controller and node over ROS 2 (~2.5 min).
demo-loop: setup
	$(VENV)/bin/frictionid loop --robot tx40 --json demo_loop.json --plots demo_loop_plots

# The lint (ruff, configured in pyproject.toml) is part of the suite: a finding fails it.
test: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/pytest -q tests -m "not long"

# The end-to-end runs of over ~15 s each (the payload loop, a whole TX40 replayed into the node, a stopped
# worker, the EMPS report, streamed experiment positions: ~3 min), apart from make test (9–11 min on 2 cores, measured 2026-11-30).
test-long: setup
	$(VENV)/bin/pytest -q tests -m long

# The quick tier: no ROS node or process, no test over ~3 s (markers in pytest.ini).
test-core: setup
	$(VENV)/bin/pytest -q tests -m "not ros and not slow"

bags: setup
	$(PY) tools/make_emps_bags.py

# Benchmarks (never part of make test). BENCH_ARGS=--quick for a smoke run.
bench-optim: setup
	$(PY) bench/optimizers.py $(BENCH_ARGS)

clean:
	rm -rf $(VENV) build demo_result.json demo_validation.json demo_loop.json demo_loop_plots
