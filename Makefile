# pairgrasp: the two commands of the README are `make demo` (the main job) and `make test`.
PYTHON    ?= python3
BUILD     ?= build/cpp
JOBS      ?= $(shell nproc 2>/dev/null || echo 2)
GENERATOR := $(shell command -v ninja >/dev/null 2>&1 && echo Ninja || echo "Unix Makefiles")
PYBIND11_DIR = $(shell $(PYTHON) -c "import pybind11; print(pybind11.get_cmake_dir())" 2>/dev/null)
OUT       ?= out/demo

.PHONY: deps build ctest install pytest test demo bench clean

deps:
	bash scripts/install_deps.sh

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) -G "$(GENERATOR)" -DCMAKE_BUILD_TYPE=Release \
	  -DPAIRGRASP_BUILD_TESTS=ON -DPAIRGRASP_BUILD_PYTHON=OFF

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

ctest: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

install: deps
	$(PYTHON) -m pip install -q --disable-pip-version-check .

pytest: install
	$(PYTHON) -m pytest tests/py -q

# Every test: C++ (ctest, including the find_package consumer) and Python (pytest).
test: ctest pytest

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
