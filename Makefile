# Two entry points (README): `make demo` runs the main job on the board
# emulator, `make test` runs every test. Both build .venv from nothing.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint format bench clean firmware-c natmod npm

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/tactile demo

# The emulated Raspberry Pi Pico's npm packages (rp2040js), into the user's cache, once.
NPM_STAMP := $(VENV)/.npm
$(NPM_STAMP): $(STAMP) sim/tactile_sim/emulator/npm/package-lock.json
	$(BIN)/python -c "from tactile_sim.emulator.pico_core import ensure_npm; ensure_npm()"
	touch $(NPM_STAMP)

npm: $(NPM_STAMP)

test: $(STAMP) $(NPM_STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/pytest -n auto --dist worksteal

lint: $(STAMP)
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

# The C core cross-compiled for a Cortex-M0 (micro:bit, as QEMU runs it): needs
# gcc-arm-none-eabi and libnewlib-arm-none-eabi (Debian).
firmware-c: $(STAMP)
	$(BIN)/python -m tactile_fw_tools.cross build/firmware-c

# The C core as a MicroPython native module for the Pico, rebuilt into the package
# (firmware/tactile_fw/tactile_native.mpy, committed: tactile flash copies it). Needs
# gcc-arm-none-eabi, pyelftools and ar (the test extra) and ../shared/rp2's natmod sources.
natmod: $(STAMP)
	$(BIN)/python -m tactile_fw_tools.natmod

bench: $(STAMP)
	for f in bench/*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info */*.egg-info
