# Set-up, demo and tests on a bare machine: every target installs what it needs first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# Exact versions of everything `make setup` installs (the ROS 2 wheels too), so that a new
# release upstream cannot change a fresh install or CI. Refreshed on purpose by `make upgrade`.
CONSTRAINTS := constraints.txt
# What is installed: the package with its ROS wheels, the Foxglove live view, Dask distributed
# (sweeps on a cluster; its tests run with a LocalCluster), test/linter tools, Sphinx for the
# docs site, the wheels that build formation_control_msgs, pytest-benchmark and JSBSim
# (plant_backend: jsbsim) (setup.py's extras).
EXTRAS := .[ros,view,cluster,test,docs,msgs-build,bench,aircraft]
# The interface package, built with cmake from those wheels and installed into the venv (its
# Python modules into site-packages, its libraries into lib/, which the ROS wheels put on the
# library path): `import formation_control_msgs.msg` and `ros2 interface show` then work in
# any process of the venv. Rebuilt when a .msg file, CMakeLists.txt or package.xml changes.
MSGS := formation_control_msgs
MSGS_BUILD := $(VENV)/build/$(MSGS)
MSGS_STAMP := $(VENV)/.installed-$(MSGS)
MSGS_SOURCES := $(wildcard $(MSGS)/msg/*.msg) $(MSGS)/CMakeLists.txt $(MSGS)/package.xml \
	tools/rosidl_wheel_includes.cmake
# tf2_msgs/msg/TFMessage (the type of /tf and /tf_static, which the monitor publishes): no
# ros-jazzy wheel has it, so third_party/tf2_msgs (that message alone, its standard definition,
# hence ROS's type hash) is built the same way, but only when the venv has no tf2_msgs of its
# own: a ROS installation's is used as it is. The stamp says which ("built" or "found").
TF2 := third_party/tf2_msgs
TF2_BUILD := $(VENV)/build/tf2_msgs
TF2_STAMP := $(VENV)/.installed-tf2_msgs
TF2_SOURCES := $(TF2)/msg/TFMessage.msg $(TF2)/CMakeLists.txt $(TF2)/package.xml \
	tools/rosidl_wheel_includes.cmake
# cmake, a C and a C++ compiler and the Python headers, checked before anything is installed:
# the package's RK4 kernel (formation_control/core/_rk4.c) is C, $(MSGS) and $(TF2) C++.
CHECK_BUILD_TOOLS := command -v cmake >/dev/null && command -v "$${CXX:-c++}" >/dev/null && \
	command -v "$${CC:-cc}" >/dev/null && \
	$(PYTHON) -c 'import os, sys, sysconfig; \
	sys.exit(not os.path.exists(sysconfig.get_paths()["include"] + "/Python.h"))' || \
	{ echo 'make setup: building the RK4 kernel, $(MSGS) and $(TF2) needs cmake, C and C++ compilers and the Python headers:' \
	'install them (Debian/Ubuntu: sudo apt-get install cmake gcc g++ python3-dev)'; exit 1; }
# The real ros2 command line (ros2cli, launch, launch_ros as wheels: not on PyPI), installed
# into the venv when present, so that the tests with `ros2` run; without it they skip, unless
# a ros2 of a Jazzy installation is on PATH.
ROS2_TOOLS ?= $(firstword $(wildcard ../shared/ros2-tools))
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export MPLBACKEND := Agg

.PHONY: setup upgrade demo test test-fast docs lint copyright bench bench-scripts bench-compare \
	envelope setup-browser clean

setup: $(STAMP) $(MSGS_STAMP) $(TF2_STAMP)

# pip, setuptools and wheel at their pins first: the package is built with them
# (--no-build-isolation), not with whatever setuptools is newest. check_pins.py fails if a
# dependency of the package is not pinned in constraints.txt.
$(STAMP): setup.py package.xml $(CONSTRAINTS) formation_control/core/_rk4.c
	@$(CHECK_BUILD_TOOLS)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -c $(CONSTRAINTS) pip setuptools wheel
	$(PY) -m pip install -c $(CONSTRAINTS) --no-build-isolation -e '$(EXTRAS)'
	$(PY) tools/check_pins.py $(CONSTRAINTS)
	$(PY) tools/ament_register.py $(VENV)
	if [ -n "$(ROS2_TOOLS)" ]; then PIP_CONSTRAINT=$(abspath $(CONSTRAINTS)) \
		"$(ROS2_TOOLS)/install.sh" $(PY); \
	else echo 'ros2-tools not found: the tests that need the ros2 CLI will skip'; fi
	touch $(STAMP)

# CMAKE_PROJECT_INCLUDE: the wheels' exported targets name their build host's Python include
# directories; tools/rosidl_wheel_includes.cmake repoints them (nothing in the venv changes).
BUILD_INTERFACES = venv=$$(cd $(VENV) && pwd); export PATH="$$venv/bin:$$PATH" \
	AMENT_PREFIX_PATH="$$venv" CMAKE_PREFIX_PATH="$$venv"; \
	cmake -S $(1) -B $(2) -DCMAKE_INSTALL_PREFIX="$$venv" -DBUILD_TESTING=OFF \
		-DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$$venv/bin/python" \
		-DCMAKE_PROJECT_INCLUDE=$(abspath tools/rosidl_wheel_includes.cmake) && \
	cmake --build $(2) -j1 && cmake --install $(2)
$(MSGS_STAMP): $(STAMP) $(MSGS_SOURCES)
	@$(CHECK_BUILD_TOOLS)
	$(call BUILD_INTERFACES,$(MSGS),$(MSGS_BUILD))
	touch $(MSGS_STAMP)

# "found": a tf2_msgs the venv had before this package built one (a ROS installation's).
$(TF2_STAMP): $(STAMP) $(TF2_SOURCES)
	@if [ "$$(cat $(TF2_STAMP) 2>/dev/null)" != built ] && \
		$(PY) -c 'import tf2_msgs.msg' 2>/dev/null; then \
		echo 'make setup: using the tf2_msgs of the ROS installation'; \
		echo found > $(TF2_STAMP); exit 0; fi; \
	$(CHECK_BUILD_TOOLS); \
	$(call BUILD_INTERFACES,$(TF2),$(TF2_BUILD)) && echo built > $(TF2_STAMP)

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

# The demo's domain is the user's own (1 + uid mod 100) unless ROS_DOMAIN_ID is set: two
# users of one host do not share it; a second fleet in one domain is refused by the swarm.
demo: setup
	ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((1 + $$(id -u) % 100))} $(VENV)/bin/formation-control swarm \
		config/rigid_circular.yaml --duration 60 --out demo.npz --plot demo.png

# Two pytest workers (pytest-xdist), each taking whole test files: the integration tests wait
# on DDS and processes much of the time, the unit tests compute. JOBS=0 runs them in this one
# process. The tests marked serial (the TLS fleet) run alone afterwards. Each phase ends with
# its slowest tests (--durations): where the time goes.
JOBS ?= 2
test: setup
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile -m 'not serial' --durations=20
	$(PY) -m pytest -q -m serial --durations=5

# The tools of the browser test (test/integration/test_browser.py: the live view in Foxglove
# Studio's web bundle): Debian's chromium and node/npm (apt-get, as root; otherwise it says what
# to install), and the exact npm packages of test/browser/package-lock.json (npm ci; no browser
# download: playwright-core drives /usr/bin/chromium).
APT_INSTALL = if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	apt-get update -qq && apt-get install -y -qq $(1); else \
	echo 'make setup-browser: install $(1) (Debian/Ubuntu: sudo apt-get install $(1))'; exit 1; fi
setup-browser:
	@command -v chromium >/dev/null || { $(call APT_INSTALL,chromium); }
	@command -v npm >/dev/null || { $(call APT_INSTALL,nodejs npm); }
	cd test/browser && npm ci --no-audit --no-fund --ignore-scripts

# The unit tests but the long simulations and the linters (test/unit: pure, no DDS; the tests
# marked slow or linter are left out: `make lint` runs the linters), in under a minute on the
# JOBS workers.
test-fast: setup
	$(PY) -m pytest -q -n $(JOBS) test/unit -m 'not slow and not linter'

# The docs site (docs/: MyST pages and the API reference of core, protocol and sim from the
# docstrings) in docs/_build/html; any warning (a broken reference, a docstring that does not
# parse) fails the build.
docs: setup
	$(PY) -m sphinx -W --keep-going -n -q -b html docs docs/_build/html

# The linters alone (flake8, pep257, copyright, mypy), as `colcon test` runs them.
lint: setup
	$(PY) -m pytest -q -m linter

# Add the Apache-2.0 header to the .py files missing it (tools/add_copyright.py).
copyright:
	$(PYTHON) tools/add_copyright.py

# The robustness envelope of issue 30 (docs/robustness.md): sensor level x model mismatch x
# gusts x seeds per law and flow source (2016 runs), then GNSS noise x the position filter; two
# workers: about 50 min of wall time and roughly 10 min of CPU on the shared, loaded machine
# (the three noisy levels: 24 min wall, 8 min CPU). Writes docs/envelope.md, envelope.png,
# envelope_noise.md.
envelope: setup
	$(PY) bench/envelope.py --seeds 8 --workers 2
	$(PY) bench/envelope.py --noise --seeds 8

# The tracked benchmarks (bench/suite, pytest-benchmark): each run is saved under .benchmarks/
# (numbered, with the commit); `make bench-compare BASE=<rev>` times a base commit against the
# work tree and fails on a regression over 20 %. bench-scripts: the detailed studies whose
# tables docs/benchmarks.md quotes.
bench: setup
	$(PY) -m pytest -q bench/suite --benchmark-autosave --benchmark-columns=median,iqr,rounds

BASE ?= HEAD
bench-compare: setup
	$(PY) tools/bench_compare.py $(BASE)

bench-scripts: setup
	$(PY) bench/sim_throughput.py
	$(PY) bench/law_cost.py
	$(PY) bench/wire.py
	$(PY) bench/fleet.py rtf --sizes 5 16
	$(PY) bench/fleet.py rtf --sizes 32 --per-process 2 4 --repeat 1 --duration 4
	$(PY) bench/fleet.py rtf --sizes 16 --graphs complete ring --per-process 1 4 8 --duration 4
	$(PY) bench/fleet.py rtf --sizes 64 --graphs complete circulant:1,2 --per-process 8 \
		--repeat 1 --duration 2
	$(PY) bench/fleet.py rtf --sizes 128 --graphs complete circulant:1,2 --per-process 16 \
		--repeat 1 --duration 1
	$(PY) bench/fleet.py rtf --sizes 32 64 --graphs ring circulant:1,2 circulant:1,2,3,4 \
		--per-process 8 --repeat 1 --duration 2
	$(PY) bench/fleet.py latency --sizes 16
	if [ "$$(id -u)" = 0 ]; then $(PY) bench/secure_fleet.py; \
	else echo 'bench/secure_fleet.py skipped: it needs root (ip netns)'; fi
	$(PY) bench/signing.py micro
	if [ "$$(id -u)" = 0 ]; then $(PY) bench/signing.py fleet; \
	else echo 'bench/signing.py fleet skipped: it needs root (ip netns)'; fi
	$(PY) bench/fleet.py latency --sizes 16 --graphs ring --per-process 4 --duration 10
	$(PY) bench/fleet.py startup --sizes 16
	$(PY) bench/sweep.py
	$(PY) bench/aircraft.py throughput
	$(PY) bench/aircraft.py throughput -p dt_integration:=0.016666666666666666
	$(PY) bench/aircraft.py lockstep
	$(PY) bench/aircraft.py steady

clean:
	rm -rf $(VENV) build install log *.egg-info demo.npz demo.png docs/_build .benchmarks
