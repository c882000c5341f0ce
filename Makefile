# Set-up, demo and tests on a bare machine: every target installs what it needs first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# Exact versions of everything `make setup` installs (the ROS 2 wheels too), so that a new
# release upstream cannot change a fresh install or CI. Refreshed on purpose by `make upgrade`.
CONSTRAINTS := constraints.txt
# What is installed: the package with its ROS wheels, the Foxglove live view, Dask distributed
# (sweeps on a cluster; its tests run with a LocalCluster) and test/linter tools (setup.py's
# extras).
EXTRAS := .[ros,view,cluster,test]
# The real ros2 command line (ros2cli, launch, launch_ros as wheels: not on PyPI), installed
# into the venv when present, so that the tests with `ros2` run; without it they skip, unless
# a ros2 of a Jazzy installation is on PATH.
ROS2_TOOLS ?= $(firstword $(wildcard ../shared/ros2-tools))
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export MPLBACKEND := Agg

.PHONY: setup upgrade demo test test-fast lint copyright bench clean

setup: $(STAMP)

# pip, setuptools and wheel at their pins first: the package is built with them
# (--no-build-isolation), not with whatever setuptools is newest. check_pins.py fails if a
# dependency of the package is not pinned in constraints.txt.
$(STAMP): setup.py package.xml $(CONSTRAINTS)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -c $(CONSTRAINTS) pip setuptools wheel
	$(PY) -m pip install -c $(CONSTRAINTS) --no-build-isolation -e '$(EXTRAS)'
	$(PY) tools/check_pins.py $(CONSTRAINTS)
	if [ -n "$(ROS2_TOOLS)" ]; then PIP_CONSTRAINT=$(abspath $(CONSTRAINTS)) \
		"$(ROS2_TOOLS)/install.sh" $(PY); \
	else echo 'ros2-tools not found: the tests that need the ros2 CLI will skip'; fi
	touch $(STAMP)

# Refresh the pins on purpose: the newest release of every dependency (and of what the
# ros2-tools installer pulls from PyPI), installed into a throw-away venv without
# constraints, frozen into constraints.txt; then `make setup` brings
# .venv to them. Review `git diff constraints.txt`, run `make test`, commit both.
upgrade:
	set -e; tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	$(PYTHON) -m venv "$$tmp/venv"; \
	"$$tmp/venv/bin/python" -m pip install --upgrade pip setuptools wheel; \
	"$$tmp/venv/bin/python" -m pip install --upgrade --no-build-isolation -e '$(EXTRAS)'; \
	if [ -n "$(ROS2_TOOLS)" ]; then ROS2_TOOLS_NO_PTH=1 "$(ROS2_TOOLS)/install.sh" \
		"$$tmp/venv/bin/python"; fi; \
	{ echo '# Exact versions of everything `make setup` installs: written by `make upgrade`'; \
	  echo '# (pip freeze of a fresh venv with the newest releases), never by hand.'; \
	  "$$tmp/venv/bin/python" -m pip freeze --all --exclude-editable; } > "$$tmp/constraints"; \
	mv "$$tmp/constraints" $(CONSTRAINTS)
	$(MAKE) setup

demo: setup
	ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-37} $(VENV)/bin/formation-control swarm \
		config/rigid_circular.yaml --duration 60 --out demo.npz --plot demo.png

test: setup
	$(PY) -m pytest -q

# The unit tests but the long simulations (test/unit: pure, no DDS; the tests marked slow
# are left out), in under a minute.
test-fast: setup
	$(PY) -m pytest -q test/unit -m 'not slow'

# The linters alone (flake8, pep257, copyright, mypy), as `colcon test` runs them.
lint: setup
	$(PY) -m pytest -q -m linter

# Add the Apache-2.0 header to the .py files missing it (tools/add_copyright.py).
copyright:
	$(PYTHON) tools/add_copyright.py

bench: setup
	$(PY) bench/sim_throughput.py
	$(PY) bench/law_cost.py
	$(PY) bench/fleet.py rtf --sizes 5 16
	$(PY) bench/fleet.py rtf --sizes 32 --per-process 2 4 --repeat 1 --duration 4
	$(PY) bench/fleet.py rtf --sizes 16 --graphs complete ring --per-process 1 4 --duration 4
	$(PY) bench/fleet.py rtf --sizes 64 --graphs complete circulant:1,2 --per-process 8 \
		--repeat 1 --duration 2
	$(PY) bench/fleet.py rtf --sizes 128 --graphs complete circulant:1,2 --per-process 16 \
		--repeat 1 --duration 1
	$(PY) bench/fleet.py rtf --sizes 32 64 --graphs ring circulant:1,2 circulant:1,2,3,4 \
		--per-process 8 --repeat 1 --duration 2
	$(PY) bench/fleet.py latency --sizes 16
	if [ "$$(id -u)" = 0 ]; then $(PY) bench/secure_fleet.py; \
	else echo 'bench/secure_fleet.py skipped: it needs root (ip netns)'; fi
	$(PY) bench/fleet.py latency --sizes 16 --graphs ring --per-process 4 --duration 10
	$(PY) bench/fleet.py startup --sizes 16
	$(PY) bench/sweep.py

clean:
	rm -rf $(VENV) build install log *.egg-info demo.npz demo.png
