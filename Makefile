# Two commands on a fresh Debian 12 machine: `make demo` and `make test`. Both install what is missing first.
VENV ?= $(CURDIR)/.venv
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
