# impactbench: `make report` runs the default report, `make test` runs the tests.
# Both create .venv and install the project with every engine on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: report test lint bench figures clean mutants

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip >/dev/null
	$(BIN)/python -m pip install -e '.[all,test]'
	touch $(STAMP)

report: $(STAMP)
	$(BIN)/impactbench figures
	$(BIN)/impactbench report --keep-unchanged

# The tests run on one process per core and one more (pytest-xdist), a test file's tests
# together (its module fixtures are built once); each process has its own results store and
# tuning cache. The extra process fills the time the others wait on subprocesses, timeouts and
# interrupts: on 2 cores, 3 workers against 2 took 0.93x the wall time (farm-bench, A/B
# alternated, medians 252 s against 272 s; CPU the same).
# Bytecode is written even where the environment says not to (PYTHONDONTWRITEBYTECODE): with
# it, pytest rewrites the asserts of every test file again in every process of every run
# (collection 9.7 s against 6.7 s a process, measured here).
test: $(STAMP)
	$(BIN)/ruff check .
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -n $$(( $$(nproc 2>/dev/null || getconf _NPROCESSORS_ONLN) + 1 )) --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)
	$(BIN)/python -m benchmarks

# Mutation testing of the references, metrics, gate judge and tuned binding (on demand, not
# in CI; ~20 min): mutmut runs in a staged copy where reference/ and engines/ sit inside
# impactbench/ as they install, so the working tree is never mutated (tools/mutants.cfg).
mutants: $(STAMP)
	rm -rf build/mutants && mkdir -p build/mutants
	cp -R impactbench tests build/mutants/
	cp -R reference build/mutants/impactbench/reference
	cp -R engines build/mutants/impactbench/engines
	find build/mutants -name __pycache__ -prune -exec rm -rf {} +
	cp tools/mutants.cfg build/mutants/setup.cfg
	cd build/mutants && ../../$(BIN)/mutmut run 'impactbench.reference.hunt_crossley.*' \
	    'impactbench.reference.models.*' 'impactbench.reference.metrics.*' \
	    'impactbench.gates.x_judge__mutmut_*' 'impactbench.gates.x_drift__mutmut_*' \
	    'impactbench.tuned.x__close__mutmut_*' 'impactbench.tuned.x_binding_mismatch__mutmut_*'; \
	  ../../$(BIN)/mutmut results

clean:
	rm -rf $(VENV) build *.egg-info
