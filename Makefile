# Two entry points that work on a fresh machine: `make demo` and `make test`.
VENV ?= .venv
BIN := $(VENV)/bin
DEMO_OUT ?= demo-out

.PHONY: setup demo test clean

$(VENV)/.installed: pyproject.toml scripts/setup.sh scripts/setup-ros2.sh src/bimrobot/rcan/backends/ros2_pkg/bimrobot_interfaces/action/ConstructionActivity.action
	VENV=$(VENV) scripts/setup.sh

setup: $(VENV)/.installed

demo: setup
	VENV=$(VENV) DEMO_OUT=$(DEMO_OUT) scripts/demo.sh

test: setup
	$(BIN)/python -m pytest -q

clean:
	[ ! -f $(DEMO_OUT)/.bimrobot-demo ] || rm -rf $(DEMO_OUT)
	rm -rf build dist src/*.egg-info
