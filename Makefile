# SSGI: `make demo` runs the main job, `make test` runs the tests. Both create .venv/ first when missing.
# Test lanes: tests/unit (bpy-free, `make test-fast`, well under a minute), tests/blender (real bpy, renders in
# subprocesses), tests/hard_cases. The unit lane runs in its own pytest process, so that its check that no
# test imports bpy is exact; `make test` runs every lane and fails if any lane fails.
PY := .venv/bin/python
STAMP := .venv/.ssgi-setup-done

.PHONY: setup demo test test-fast build validate clean

setup: $(STAMP)

$(STAMP): requirements.lock scripts/setup.sh
	bash scripts/setup.sh

demo: $(STAMP)
	$(PY) cli.py demo --out out/demo

test-fast: $(STAMP)
	$(PY) -m pytest -q tests/unit

test: $(STAMP)
	$(PY) -m pytest -q tests/unit; unit=$$?; \
	$(PY) -m pytest -q tests/blender tests/hard_cases && exit $$unit

build: $(STAMP)
	$(PY) scripts/blender_ext.py build --source-dir . --output-dir dist --split-platforms

validate: $(STAMP)
	$(PY) scripts/blender_ext.py validate .

clean:
	rm -rf dist out .pytest_cache
