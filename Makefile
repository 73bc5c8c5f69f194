# Two commands: `make run` and `make test`. Both install whatever is missing first.
.PHONY: install run test test-slow test-long test-all docs docs-gallery typecheck bench doctor clean

ECOSTUDY := .venv/bin/ecostudy
# pytest-xdist processes: the suite runs in two on this machine kind's two cores
TEST_WORKERS ?= 2
PYTEST := .venv/bin/python -m pytest -q -n $(TEST_WORKERS)

install:
	@bash scripts/install.sh

run: install
	$(ECOSTUDY) solve studies/default.yaml

test: install
	$(PYTEST) -m "not slow"

test-slow: install
	$(PYTEST) -m "slow and not long"

test-long: install
	$(PYTEST) -m long

test-all: install
	$(PYTEST)

# the guide (docs/, mkdocs.yml) as a site in site/; --strict: a broken link or reference fails the build
docs: install
	NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --site-dir site

# the same with the examples gallery executed, so its pages show their tables and figures (minutes)
docs-gallery: install
	ECOSTUDY_GALLERY_EXECUTE=true NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --site-dir site

typecheck: install
	.venv/bin/mypy ecostudy

doctor: install
	$(ECOSTUDY) doctor

bench: install
	.venv/bin/python bench/bench_solve.py

clean:
	rm -rf out site .pytest_cache
