# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint unit bench campaign clean venv

venv: $(STAMP)

# Re-install only when the project's dependencies change (idempotent and fast when nothing changed).
$(STAMP): pyproject.toml
	command -v chromium >/dev/null && command -v chromedriver >/dev/null || \
		{ apt-get update -qq && apt-get install -y -qq chromium chromium-driver >/dev/null; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m hil_sim demo

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/lint-imports
	$(BIN)/python -m tests.import_contract

unit: $(STAMP)
	$(BIN)/python -m pytest -q tests/unit

test: lint
	$(BIN)/python -m pytest -q

# A short campaign (the paper's scenarios x 5 seeds); prints where the report is, opens nothing.
campaign: $(STAMP)
	$(BIN)/auv-hil campaign hil_sim/campaigns/paper.yaml --out out/campaign/paper

bench: $(STAMP)
	$(BIN)/auv-bench --json bench.json

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache build *.egg-info
