# SSGI: `make demo` runs the main job, `make test` runs the tests. Both create .venv/ first when missing.
PY := .venv/bin/python
STAMP := .venv/.ssgi-setup-done

.PHONY: setup demo test bench build validate clean

setup: $(STAMP)

$(STAMP): requirements.lock scripts/setup.sh
	bash scripts/setup.sh

demo: $(STAMP)
	$(PY) cli.py demo --out out/demo

test: $(STAMP)
	$(PY) -m pytest -q tests

build: $(STAMP)
	$(PY) scripts/blender_ext.py build --source-dir . --output-dir dist

validate: $(STAMP)
	$(PY) scripts/blender_ext.py validate .

clean:
	rm -rf dist out .pytest_cache
