# Two commands on a fresh Debian 12 machine: `make demo` and `make test`. Both install what is missing first.
VENV ?= $(CURDIR)/.venv
# ros2_bridge's ROS 2 half runs in its own venv, made by `MRS_NAV_ROS2=1 make install` (tools/install_ros2.sh).
VENV_ROS2 ?= $(CURDIR)/.venv-ros2
export VENV_ROS2
PY := $(VENV)/bin/python
OUT ?= $(CURDIR)/demo_out
export PATH := $(VENV)/bin:$(PATH)

.PHONY: install demo test lint unit figures bench clean

install:
	@VENV=$(VENV) bash tools/install.sh
	@$(VENV)/bin/python -m mrs_nav.jit

demo: install
	$(VENV)/bin/mrs-nav figures --out $(OUT)/figures
	$(VENV)/bin/mrs-nav demo --out $(OUT)

lint: install
	$(VENV)/bin/ruff check src tests $(wildcard scripts/*)
	$(VENV)/bin/mypy

# The test run makes the ROS 2 venv too, so that the ros2_bridge tests run rather than skip.
test: export MRS_NAV_ROS2 := 1

# pytest exits 5 when it collected no test: that is a broken suite, not a pass.
test: lint
	@$(PY) -m pytest; rc=$$?; \
	  if [ $$rc -eq 5 ]; then echo 'make test: pytest collected no tests' >&2; exit 1; fi; exit $$rc

figures: install
	$(VENV)/bin/mrs-nav figures --out $(OUT)/figures

bench: install
	for b in potential-field planners simulator slam navigation replay replay-batch bridge localisation; do \
	  $(VENV)/bin/mrs-nav bench $$b || exit 1; done

clean:
	rm -rf $(OUT) build devel .pytest_cache .mypy_cache .ruff_cache
