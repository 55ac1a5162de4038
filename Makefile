# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test check lint unit bench campaign clean venv

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

# The documentation site (mkdocs.yml, docs/) into site/; --strict: a broken link, a missing page or a
# missing included file fails the build.
.PHONY: docs
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

# The tiers are markers (tests/conftest.py): unit (one process), integration, e2e (real processes).
unit: $(STAMP)
	$(BIN)/python -m pytest -q -n auto -m unit tests/unit

# Before a commit: lint and the unit tier, in about a minute.
check: lint unit

# The whole suite in parallel: pytest-xdist, 4 workers (2 per core on the 2-core target: most tests wait on
# real-time processes); the tests that flood the machine or judge it in real time are one group, run one
# after the other on one worker (tests/conftest.py GROUPS).
TEST_WORKERS ?= 4
test: lint docs
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadgroup

# A short campaign (the paper's scenarios x 5 seeds); prints where the report is, opens nothing.
campaign: $(STAMP)
	$(BIN)/auv-hil campaign hil_sim/campaigns/paper.yaml --out out/campaign/paper

bench: $(STAMP)
	$(BIN)/auv-bench --json bench.json

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache build *.egg-info site
