# Volpath: `make test` and `make sunrise` set everything up on a fresh Debian 12 machine.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
# Debian packages the build needs (installed only when missing; OpenVDB and the Boost
# headers it includes, for volpath._vdb; clang-format for `make lint`). The Python headers and
# venv come from Debian only when the Python in use lacks them.
DEBIAN_PACKAGES := g++ make libopenvdb-dev libboost-iostreams-dev clang-format
PY_NEEDS := $(shell $(PYTHON) -c "import ensurepip, venv" 2>/dev/null || echo python3-venv) \
            $(shell $(PYTHON) -c "import sysconfig, os, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()['include'], 'Python.h')))" 2>/dev/null || echo python3-dev)
NATIVE_SOURCES := $(shell find native -name '*.cpp' -o -name '*.h' -o -name CMakeLists.txt) pyproject.toml
SUNRISE_BLEND := scenes/sunrise/sunrise.blend
SPP ?= 40
TARGET ?= 0.03
DENOISE ?= --denoise
RES ?= 320x180
FRAMES ?= 1-72
JOBS ?= 2

.PHONY: all setup test lint format stubs bench accuracy sunrise clean debian fuzz sanitize wheel extension

all: test

debian:
	@missing=""; for p in $(DEBIAN_PACKAGES) $(PY_NEEDS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:$$missing"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi

$(VENV)/.requirements: requirements.txt | debian
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q -r requirements.txt
	touch $@

# The native module, rebuilt incrementally (build/) whenever a C++ source changes.
$(VENV)/.native: $(VENV)/.requirements $(NATIVE_SOURCES) $(shell find volpath -name '*.py')
	$(PIP) install -q --no-build-isolation --no-deps -e .
	touch $@

setup: debian $(VENV)/.native

test: setup
	$(VENV)/bin/pytest -n $(JOBS) --dist loadgroup -q tests

# Style: ruff (lint and format, pyproject.toml) for Python, clang-format (.clang-format) for C++;
# mypy for the public API's type hints (against the native module's stub, volpath/_core.pyi);
# lizard for the core's functions: none over 120 lines or 30 decision points, so that each
# estimator reads in one sitting.
CXX_SOURCES := $(shell find native -name '*.cpp' -o -name '*.h')
lint: debian $(VENV)/.requirements
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	clang-format --dry-run --Werror $(CXX_SOURCES)
	$(VENV)/bin/mypy
	$(VENV)/bin/lizard -l cpp --length 120 --CCN 30 --warnings_only native/src

# volpath/_core.pyi, the native module's type stub, generated from the built module.
stubs: setup
	$(PY) tests/python/test_stubs.py --update

format: debian $(VENV)/.requirements
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .
	clang-format -i $(CXX_SOURCES)

$(VENV)/.bench: requirements-bench.txt $(VENV)/.requirements
	$(PIP) install -q -r requirements-bench.txt
	@dpkg -s libllvm19 >/dev/null 2>&1 || { SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq libllvm19 || \
	  echo "libllvm19 unavailable: Mitsuba's llvm variant will be skipped"; }
	touch $@

bench: setup $(VENV)/.bench $(SUNRISE_BLEND)
	$(PY) bench/compare_mitsuba.py --append bench/RESULTS.md
	$(PY) bench/export_speed.py --append bench/RESULTS.md
	$(PY) bench/pipeline_throughput.py --append bench/RESULTS.md
	$(PY) bench/frame_reuse.py --append bench/RESULTS.md
	$(PY) bench/animation_cost.py --append bench/RESULTS.md
	$(PY) bench/motion_blur.py --append bench/RESULTS.md
	$(PY) bench/surfaces.py --append bench/RESULTS.md
	$(PY) bench/many_lights.py --append bench/RESULTS.md
	$(PY) bench/cycles_sunrise.py --append bench/RESULTS.md
	$(PY) bench/cycles_sunrise.py --sky --append bench/RESULTS.md
	test -f out/sunrise/summary.json || $(MAKE) sunrise
	$(PY) bench/sunrise_quality.py --append bench/RESULTS.md
	$(PY) bench/sparse_cloud.py --append bench/RESULTS.md
	$(PY) bench/mesh_loading.py --sizes 100000 1000000 10000000 --append bench/RESULTS.md --plot docs/mesh_loading.png
	$(PY) bench/instance_scaling.py --append bench/RESULTS.md --plot docs/instance_scaling.png
	$(PY) bench/cloud_scaling.py --append bench/RESULTS.md --plot docs/cloud_scaling.png
	$(PY) bench/spectral_sky.py --append bench/RESULTS.md
	$(PY) bench/spectral_sunrise.py --append bench/RESULTS.md

# The self-contained manylinux wheel that the Blender extension bundles (dist/).
wheel: setup
	rm -rf dist && mkdir -p dist
	$(PIP) wheel -q --no-build-isolation --no-deps -Cbuild-dir=build/wheel -Ccmake.define.VOLPATH_PROBES=OFF -w dist/raw .
	PATH="$(abspath $(VENV))/bin:$$PATH" $(PY) -m auditwheel repair -w dist dist/raw/volpath-*.whl
	rm -rf dist/raw && ls dist

# The Blender extension zip (dist/volpath-*.zip), built and validated by Blender's own
# extension tool; it bundles the native wheel and the pure-Python wheels it needs.
BLENDER_EXT = $$($(PY) -c "import importlib.util, os; print(os.path.join(importlib.util.find_spec('bpy').submodule_search_locations[0], '5.0/scripts/addons_core/bl_pkg/cli/blender_ext.py'))")
extension: wheel
	rm -rf wheels && mkdir -p wheels
	cp dist/volpath-*.whl wheels/
	$(PIP) download -q --only-binary :all: --no-deps -d wheels $$(grep -E '^(OpenEXR|tqdm|pillow|imageio-ffmpeg|pyoidn|cffi|pycparser)==' requirements.txt)
	$(PY) $(BLENDER_EXT) validate .
	$(PY) $(BLENDER_EXT) build --source-dir . --output-dir dist --split-platforms
	@ls -la dist/*.zip

# The accuracy study: docs/accuracy.md and its plots (references cached in bench/cache/),
# with denoising's section.
accuracy: setup $(VENV)/.bench $(SUNRISE_BLEND)
	$(PY) bench/accuracy/run.py
	$(PY) bench/accuracy/denoise.py

# The default sunrise: the scene is built by its script, then the pipeline renders FRAMES
# at RES, each to the display error TARGET (SPP samples at most; TARGET=0: SPP each),
# denoised (DENOISE= to turn it off), to out/sunrise/ (frames/*.exr, sunrise.mp4,
# contact_sheet.png, summary.json).
$(SUNRISE_BLEND): scenes/sunrise/build.py $(VENV)/.native
	$(PY) scenes/sunrise/build.py $@

sunrise: setup $(SUNRISE_BLEND)
	$(PY) -m addon.sunrise --blend $(SUNRISE_BLEND) --frames $(FRAMES) --spp $(SPP) --target-error $(TARGET) \
	  $(DENOISE) --res $(RES) --out out/sunrise
	@echo "video: out/sunrise/sunrise.mp4"

# Many more hostile inputs than `make test` runs.
fuzz: setup
	FUZZ_EXAMPLES=$${FUZZ_EXAMPLES:-20000} $(VENV)/bin/pytest -q tests/stability/test_fuzz.py

# The core built with AddressSanitizer and UndefinedBehaviorSanitizer in its own
# environment, then the native and stability tests (leak checking is off: CPython's
# allocations at exit are not ours).
SAN_VENV := .venv-sanitize
sanitize: setup
	test -x $(SAN_VENV)/bin/python || $(PYTHON) -m venv $(SAN_VENV)
	$(SAN_VENV)/bin/pip install -q -r requirements.txt
	$(SAN_VENV)/bin/pip install -q --no-build-isolation --no-deps -Cbuild-dir=build/sanitize \
	  -Ccmake.define.VOLPATH_SANITIZE=ON .
	cd tests && LD_PRELOAD="$$(g++ -print-file-name=libasan.so) $$(g++ -print-file-name=libubsan.so)" \
	  ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	  FUZZ_EXAMPLES=200 ../$(SAN_VENV)/bin/pytest -q -p no:cacheprovider native stability \
	  python/test_meshes.py python/test_instances.py

clean:
	rm -rf build out dist wheels $(VENV) $(SAN_VENV)
