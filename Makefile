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

# The suite in two runs: most tests on TEST_WORKERS processes (one test file per worker, so a file's
# module fixtures are computed once; tests/test_real_models.py one model per worker, dearest first:
# tests/conftest.py groups them), then the tests whose robots, services or browser keep real time
# alone, so a loaded machine cannot make them late.
TEST_WORKERS ?= 2
SERIAL_TESTS := ros or redis or browser or chaos

test: setup
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not ($(SERIAL_TESTS))"
	$(BIN)/python -m pytest -q -m "$(SERIAL_TESTS)"

clean:
	[ ! -f $(DEMO_OUT)/.bimrobot-demo ] || rm -rf $(DEMO_OUT)
	rm -rf build dist src/*.egg-info
