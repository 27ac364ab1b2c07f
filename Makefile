# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv on first use.
SHELL := /bin/bash
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export MPLBACKEND := Agg

.PHONY: venv demo test bench clean

venv: $(STAMP)

PKG := steer_monitor
MSGS := steer_monitor_msgs
MSG_FILES := $(wildcard $(MSGS)/msg/*.msg)

$(STAMP): $(PKG)/setup.py $(PKG)/setup.cfg $(PKG)/package.xml $(MSGS)/package.xml $(MSGS)/CMakeLists.txt $(MSG_FILES) \
          requirements-ros.txt requirements-dev.txt constraints.txt
	@$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "need Python 3.11, found " + sys.version' \
	  || { echo "make: set PYTHON=/path/to/python3.11" >&2; exit 1; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -c constraints.txt pip setuptools wheel
	$(BIN)/python -m pip install -c constraints.txt -r requirements-ros.txt -r requirements-dev.txt
	$(BIN)/python -m pip install -c constraints.txt -e './$(PKG)[ashore]'
	@# the message package, built with colcon from the wheels and installed into the venv
	@# (its libraries in .venv/lib, where the wheels' own are found)
	env PATH="$(abspath $(BIN)):$$PATH" VIRTUAL_ENV="$(abspath $(VENV))" CMAKE_PREFIX_PATH="$(abspath $(VENV))" \
	  AMENT_PREFIX_PATH="$(abspath $(VENV))" $(BIN)/colcon --log-base build/log build --base-paths $(MSGS) \
	  --build-base build/colcon --install-base $(VENV) --merge-install \
	  --cmake-args -DPython3_EXECUTABLE="$(abspath $(BIN))/python" -DBUILD_TESTING=OFF
	touch $@

demo: $(STAMP)
	$(BIN)/steer-monitor demo --out $(OUT)

test: $(STAMP)
	cd $(PKG) && "$(abspath $(BIN))/python" -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	$(BIN)/python bench/run.py

clean:
	rm -rf $(VENV) $(OUT) build install log .pytest_cache
