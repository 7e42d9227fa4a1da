# pairgrasp: the two commands of the README are `make demo` (the main job) and `make test` (minutes);
# `make check` (what .ci/run calls) adds the slow tests, the sanitizer build and the fuzzers.
PYTHON    ?= python3
BUILD     ?= build/cpp
JOBS      ?= $(shell nproc 2>/dev/null || echo 2)
GENERATOR := $(shell command -v ninja >/dev/null 2>&1 && echo Ninja || echo "Unix Makefiles")
PYBIND11_DIR = $(shell $(PYTHON) -c "import pybind11; print(pybind11.get_cmake_dir())" 2>/dev/null)
# The Release build and the wheel's compile the library with the same compiler and flags: through
# ccache (when installed), the second compiles almost nothing. CMake's default compiler is c++; the
# wheel's build is told so (it would take g++, the same compiler under a name ccache tells apart).
CCACHE      = $(shell command -v ccache 2>/dev/null)
LAUNCHER    = $(if $(CCACHE),-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
WHEEL_CXX   = $(shell grep -s '^CMAKE_CXX_COMPILER:' $(BUILD)/CMakeCache.txt | cut -d= -f2)
WHEEL_CACHE = $(if $(CCACHE),--config-settings=cmake.define.CMAKE_CXX_COMPILER_LAUNCHER=ccache \
              $(if $(WHEEL_CXX),--config-settings=cmake.define.CMAKE_CXX_COMPILER=$(WHEEL_CXX)))
# pytest spreads the tests over this many processes (pytest-xdist); 0 runs them in one.
PYTEST_JOBS ?= $(JOBS)
PYTEST    = $(PYTHON) -m pytest -n $(PYTEST_JOBS)
OUT       ?= out/demo
# Sanitizer and fuzzing builds, each in its own folder (see docs/reliability.md).
ASAN_BUILD ?= build/asan
FUZZ_BUILD ?= build/fuzz
TSAN_BUILD ?= build/tsan
FUZZ_TIME  ?= 30
ASAN_CXX   ?= g++
SAN_CONFIG = -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1"
ASAN_ENV   = ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0 \
             UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# The Python tests against the sanitized extension: the interpreter is not instrumented, so the
# ASan runtime is preloaded, and Python's own allocations are not reported as leaks. libstdc++ is
# preloaded too: ASan finds the real __cxa_throw at start-up, and the interpreter does not link
# libstdc++, so without it the first C++ exception aborts in ASan's interceptor.
ASAN_PY_ENV = LD_PRELOAD="$$($(ASAN_CXX) -print-file-name=libasan.so) $$($(ASAN_CXX) -print-file-name=libstdc++.so)" \
             PYTHONPATH=$(ASAN_BUILD)/python \
             ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
             PAIRGRASP_SANITIZED=1

.PHONY: deps build ctest install pytest pytest-slow test check demo bench clean asan asan-build asan-ctest asan-pytest fuzz tsan

deps:
	bash scripts/install_deps.sh

# One Release build for the C++ tests and the Python tests: the library, the GoogleTest programs and
# the extension, which $(BUILD)/python/pairgrasp holds beside links to the Python sources (so pytest
# runs with PYTHONPATH=$(BUILD)/python, without building a wheel). Configured every time (cheap when
# nothing changed), so a build folder configured without the extension gets it.
build: deps
	cmake -S . -B $(BUILD) -G "$(GENERATOR)" -DCMAKE_BUILD_TYPE=Release $(LAUNCHER) \
	  -DPAIRGRASP_BUILD_TESTS=ON -DPAIRGRASP_BUILD_PYTHON=ON -DPython_EXECUTABLE=$$(command -v $(PYTHON)) \
	  -Dpybind11_DIR=$(PYBIND11_DIR) >/dev/null
	cmake --build $(BUILD) -j $(JOBS)

ctest: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# What users run: the package built and installed by pip (scikit-build-core).
install: deps
	$(PYTHON) -m pip install -q --disable-pip-version-check $(WHEEL_CACHE) .

pytest: build
	PYTHONPATH=$(BUILD)/python $(PYTEST) tests/py -q -m "not slow"

# The tests marked slow (the longer end-to-end plans and CLI runs), against the pip-installed package.
pytest-slow: install
	$(PYTEST) tests/py -q -m slow -p no:cacheprovider

# The README's test command, in minutes: C++ (ctest, including the find_package consumer) and the
# Python tests but the slow ones.
test: ctest pytest

# Everything CI checks (.ci/run): `make test`, the slow tests against the installed package, the
# C++ tests and the Python tests but the slow ones against an ASan + UBSan build, bounded fuzzing,
# then the concurrency tests under ThreadSanitizer.
check: test pytest-slow asan fuzz tsan

# ASan + UBSan: the library, its C++ tests and the Python extension in $(ASAN_BUILD).
$(ASAN_BUILD)/CMakeCache.txt:
	cmake -S . -B $(ASAN_BUILD) -G "$(GENERATOR)" $(SAN_CONFIG) $(LAUNCHER) -DCMAKE_CXX_COMPILER=$(ASAN_CXX) -DPAIRGRASP_SANITIZE=ON \
	  -DPAIRGRASP_BUILD_TESTS=ON -DPAIRGRASP_BUILD_PYTHON=ON -DPython_EXECUTABLE=$$(command -v $(PYTHON)) \
	  -Dpybind11_DIR=$(PYBIND11_DIR)

asan-build: deps $(ASAN_BUILD)/CMakeCache.txt
	cmake --build $(ASAN_BUILD) -j $(JOBS)

# The examples tests are left to the plain ctest: they build uninstrumented programs.
asan-ctest: asan-build
	$(ASAN_ENV) ctest --test-dir $(ASAN_BUILD) --output-on-failure -j $(JOBS) -E "find_package_consumer|plan_grasps_example"

# The tests but the slow and the long ones: those are whole plans through the C++ paths that ctest
# and the shorter tests already run here, and ASan makes them about nine times slower; with them
# this step alone took up to 45 minutes of CI's 90 on a loaded day (docs/reliability.md).
asan-pytest: asan-build install
	$(ASAN_PY_ENV) $(PYTEST) tests/py -q -m "not slow and not long" -p no:cacheprovider --durations=10

asan: asan-ctest asan-pytest

# libFuzzer harnesses (clang, ASan + UBSan) and the atheris one, FUZZ_TIME seconds each.
$(FUZZ_BUILD)/CMakeCache.txt:
	cmake -S . -B $(FUZZ_BUILD) -G "$(GENERATOR)" $(SAN_CONFIG) $(LAUNCHER) -DCMAKE_CXX_COMPILER=clang++ \
	  -DPAIRGRASP_BUILD_FUZZ=ON -DPAIRGRASP_BUILD_TESTS=OFF

fuzz: deps install $(FUZZ_BUILD)/CMakeCache.txt
	cmake --build $(FUZZ_BUILD) -j $(JOBS)
	bash scripts/run_fuzz.sh $(FUZZ_BUILD) $(FUZZ_TIME) $(PYTHON)

# ThreadSanitizer (part of `check`, not of `test`): the concurrency tests, whose shared-planner search
# runs the whole pipeline (align, settle, evaluate, fine-tune, robust scoring) from several threads.
$(TSAN_BUILD)/CMakeCache.txt:
	cmake -S . -B $(TSAN_BUILD) -G "$(GENERATOR)" $(SAN_CONFIG) $(LAUNCHER) -DPAIRGRASP_TSAN=ON -DPAIRGRASP_BUILD_TESTS=ON

tsan: deps $(TSAN_BUILD)/CMakeCache.txt
	cmake --build $(TSAN_BUILD) -j $(JOBS) --target test_concurrency
	TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 $(TSAN_BUILD)/tests/cpp/test_concurrency

# The main job on the bundled models: grasps.json and pictures in $(OUT).
demo: install
	pairgrasp plan --hand models/barrett/barrett.json --target models/targets/flask.stl \
	  --paint models/targets/flask.paint.json --top 5 --seed 1 -o $(OUT)

bench: deps
	cmake -S . -B build/bench -G "$(GENERATOR)" -DCMAKE_BUILD_TYPE=Release \
	  -DPAIRGRASP_BUILD_TESTS=OFF -DPAIRGRASP_BUILD_BENCH=ON
	cmake --build build/bench -j $(JOBS)

clean:
	rm -rf build out
