# Set-up, demo and tests on a bare machine: every target installs what it needs first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export MPLBACKEND := Agg

.PHONY: setup demo test bench clean

setup: $(STAMP)

$(STAMP): setup.py package.xml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip
	$(PY) -m pip install "ros-jazzy-rclpy[fastrtps]" ros-jazzy-common-interfaces \
		ros-jazzy-domain-coordinator \
		numpy matplotlib pyyaml pytest rosbags colcon-common-extensions
	$(PY) -m pip install --no-deps -e .
	touch $(STAMP)

demo: setup
	ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-37} $(VENV)/bin/formation-control swarm \
		config/rigid_circular.yaml --duration 60 --out demo.npz --plot demo.png

test: setup
	$(PY) -m pytest -q

bench: setup
	$(PY) bench/sim_throughput.py
	$(PY) bench/law_cost.py
	$(PY) bench/fleet.py rtf --sizes 5 16
	$(PY) bench/fleet.py rtf --sizes 32 --per-process 2 4 --repeat 1 --duration 4
	$(PY) bench/fleet.py rtf --sizes 64 --per-process 8 --repeat 1 --duration 2
	$(PY) bench/fleet.py rtf --sizes 128 --per-process 16 --repeat 1 --duration 1
	$(PY) bench/fleet.py latency --sizes 16
	$(PY) bench/fleet.py startup --sizes 16

clean:
	rm -rf $(VENV) build install log *.egg-info demo.npz demo.png
