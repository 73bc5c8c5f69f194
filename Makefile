# Two commands: `make run` and `make test`. Both install whatever is missing first.
.PHONY: install run test test-slow test-all bench doctor clean

ECOSTUDY := .venv/bin/ecostudy

install:
	@bash scripts/install.sh

run: install
	$(ECOSTUDY) solve studies/default.yaml

test: install
	.venv/bin/python -m pytest -q -m "not slow"

test-slow: install
	.venv/bin/python -m pytest -q -m slow

test-all: install
	.venv/bin/python -m pytest -q

doctor: install
	$(ECOSTUDY) doctor

bench: install
	.venv/bin/python bench/bench_solve.py

clean:
	rm -rf out .pytest_cache
