# voxlab — build, test, benchmark and demo targets. `make` builds build/voxlab.
# SANITIZE=1 builds everything into build-asan/ with AddressSanitizer + UndefinedBehaviorSanitizer.

# SANITIZE=fuzz builds the library with Debian's clang for libFuzzer into build-fuzz/ (see `make fuzz`).

SANITIZE ?= 0
# Error messages are built with snprintf into fixed buffers; truncating a very long path is fine.
NOWARN = -Wno-format-truncation
CC = gcc
CXX = g++
ifeq ($(SANITIZE),1)
BUILD ?= build-asan
SANFLAGS = -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
OPT = -O1
else ifeq ($(SANITIZE),fuzz)
BUILD ?= build-fuzz
CC = clang
CXX = clang++
NOWARN =
SANFLAGS = -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
OPT = -O1
else
BUILD ?= build
SANFLAGS =
# -O3: 5-10 % off the render (bunny 256^3, one thread: alpha 162 -> 154 ms, binary 79 -> 71 ms), images
# and .vox files bit-identical to -O2 (no reassociation without -ffast-math, no FMA on x86-64-v2).
OPT = -O3
endif
# Every folder of the tracer and the models is on the include path (headers are named by file, not
# by folder), so a new model folder needs no Makefile edit. The OpenCL program assembler searches the
# same folders, in this order (SOURCE_DIRS is written into the embedded source table).
# tracer/api/ (the Python library's functions, not the binary's) is left out: no kernel source there.
SOURCE_DIRS := $(sort $(filter-out tracer/api,$(shell find tracer models -type d))) scenes/generators
INCLUDES = $(addprefix -I,$(SOURCE_DIRS)) -I/usr/include/embree3 -I/usr/include/OpenEXR
CFLAGS = -std=c11 $(OPT) -g -march=x86-64-v2 -Wall -Wextra -Werror $(NOWARN) -D_GNU_SOURCE -pthread -MMD -MP $(INCLUDES) $(SANFLAGS)
CXXFLAGS = -std=c++17 $(OPT) -g -Wall -Wextra -Werror -pthread -MMD -MP $(INCLUDES) $(SANFLAGS)
# -rdynamic: the OpenImageIO plugin calls back into the executable (see tracer/image/image_oiio.cpp).
LDFLAGS = -pthread -rdynamic $(SANFLAGS)
LDLIBS = -lembree3 -lOpenEXRCore -ltinygltf -lstb -ltinyobjloader -lcjson -lOpenCL -lm -ldl
PLUGIN = $(BUILD)/libvoxlab_oiio.so

# Every source file of the library; main.c is the CLI only, tracer/api/ the Python library's only.
API_SRC = $(wildcard tracer/api/*.c)
LIB_SRC = $(filter-out tracer/cli/main.c tracer/image/image_oiio.cpp $(API_SRC),$(sort $(shell find tracer models -name '*.c' -o -name '*.cpp')) $(wildcard scenes/generators/*.c))
# The OpenCL kernels' sources (every header and .cl of those folders), embedded in the binary.
KERNEL_SOURCES := $(shell find $(SOURCE_DIRS) -maxdepth 1 -type f \( -name '*.h' -o -name '*.cl' \))
EMBEDDED = $(BUILD)/gen/embedded_sources.c
LIB_OBJ = $(patsubst %,$(BUILD)/%.o,$(LIB_SRC)) $(EMBEDDED).o
UNIT_SRC = $(wildcard tests/unit_*.c)
UNIT_BIN = $(patsubst tests/%.c,$(BUILD)/tests/%,$(UNIT_SRC))
BENCH_SRC = $(wildcard tests/bench_*.c)
BENCH_BIN = $(patsubst tests/%.c,$(BUILD)/tests/%,$(BENCH_SRC))

# libFuzzer harnesses (tests/fuzz/fuzz_NAME.c), built with SANITIZE=fuzz.
FUZZ_NAMES = scene ply obj gltf vox image
FUZZ_BIN = $(patsubst %,$(BUILD)/fuzz/fuzz_%,$(FUZZ_NAMES))
FUZZ_SECONDS ?= 60
# Debian's clang and its libFuzzer runtime, for `make fuzz` only.
FUZZ_DEPS = clang libclang-rt-14-dev

# Debian packages voxlab needs to build and test (see README).
DEPS = build-essential libembree-dev libopenexr-dev libopenimageio-dev libtinygltf-dev libstb-dev libtinyobjloader-dev libcjson-dev \
       ocl-icd-opencl-dev opencl-headers pocl-opencl-icd \
       python3-numpy python3-skimage python3-matplotlib python3-pil python3-openimageio python3-mpmath

.PHONY: all deps test test-asan bench bench-build demo clean fuzz fuzz-build pylib
all: $(BUILD)/voxlab

$(BUILD)/voxlab: $(BUILD)/tracer/cli/main.c.o $(LIB_OBJ) | $(PLUGIN)
	$(CXX) $(LDFLAGS) -o $@ $^ $(LDLIBS)

$(PLUGIN): tracer/image/image_oiio.cpp tracer/image/image.h tracer/core/error.h tracer/core/readfile.h
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -fPIC -shared -o $@ $< -lOpenImageIO -lOpenImageIO_Util

# The Python API's library (tracer/api/voxlab_api.h, used by experiments/voxlab/): the library's
# sources compiled again as position-independent code into $(BUILD)/pic/ (Debian's gcc makes the
# executable's objects PIE, which a shared library cannot hold), so the CLI's own objects and
# timings stay as they are. The OpenImageIO plugin is found beside it.
PYLIB = $(BUILD)/libvoxlab.so
PIC_OBJ = $(patsubst %,$(BUILD)/pic/%.o,$(LIB_SRC) $(API_SRC)) $(BUILD)/pic/gen/embedded_sources.c.o
pylib: $(PYLIB)

$(PYLIB): $(PIC_OBJ) | $(PLUGIN)
	$(CXX) $(LDFLAGS) -shared -o $@ $^ $(LDLIBS)

$(BUILD)/pic/gen/embedded_sources.c.o: $(EMBEDDED)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -fPIC -c -o $@ $<

$(BUILD)/pic/%.c.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -fPIC -c -o $@ $<

$(BUILD)/pic/%.cpp.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -fPIC -c -o $@ $<

$(EMBEDDED): tracer/backends/opencl/embed_sources.sh $(KERNEL_SOURCES) Makefile
	@mkdir -p $(dir $@)
	sh $< $@ $(SOURCE_DIRS)

# The version `voxlab --version` prints: the commit (git describe), rewritten only when it changes so
# that an unchanged tree rebuilds nothing; and how this build compiles (the compiler and its flags,
# without the include paths and dependency files), which experiments put into every cached job's key
# (experiments/code_keys.py): the Makefile's own lines do not show `make OPT=-O0` or SANITIZE=1,
# whose timings must not be filed with an -O3 build's.
VERSION_H = $(BUILD)/gen/version.h
VERSION_TEXT := $(shell git describe --always --dirty --tags 2>/dev/null || echo unknown)
BUILD_TEXT = $(CC) $(filter-out -I% -MMD -MP,$(CFLAGS))
$(VERSION_H): FORCE
	@mkdir -p $(dir $@)
	@printf '#define VOXLAB_VERSION "%s"\n#define VOXLAB_BUILD "%s"\n' "$(VERSION_TEXT)" "$(BUILD_TEXT)" >$@.tmp
	@cmp -s $@.tmp $@ && rm -f $@.tmp || mv $@.tmp $@
FORCE:
$(BUILD)/tracer/cli/version.c.o: $(VERSION_H)
$(BUILD)/tracer/cli/version.c.o: CFLAGS += -I$(BUILD)/gen
$(BUILD)/pic/tracer/cli/version.c.o: $(VERSION_H)
$(BUILD)/pic/tracer/cli/version.c.o: CFLAGS += -I$(BUILD)/gen

$(EMBEDDED).o: $(EMBEDDED)
	$(CC) $(CFLAGS) -c -o $@ $<

$(BUILD)/%.c.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c -o $@ $<

$(BUILD)/%.cpp.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -c -o $@ $<

$(BUILD)/tests/%: tests/%.c $(LIB_OBJ) | $(PLUGIN)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -Itests -c -o $@.o $<
	$(CXX) $(LDFLAGS) -o $@ $@.o $(LIB_OBJ) $(LDLIBS)

# The fuzz harnesses link libFuzzer's main; the image harness also links the OpenImageIO shim
# directly (voxlab itself loads it as a plugin).
$(BUILD)/fuzz/fuzz_%: tests/fuzz/fuzz_%.c tests/fuzz/fuzz_common.h $(LIB_OBJ) $(BUILD)/tracer/image/image_oiio.cpp.o | $(PLUGIN)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -Itests/fuzz -c -o $@.o $<
	$(CXX) $(LDFLAGS) -fsanitize=fuzzer -o $@ $@.o $(LIB_OBJ) $(if $(findstring image,$*),$(BUILD)/tracer/image/image_oiio.cpp.o -lOpenImageIO -lOpenImageIO_Util) $(LDLIBS)

# Installs missing Debian packages; costs well under a second when everything is present.
deps:
	@missing=$$(for p in $(DEPS) $(EXTRA_DEPS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing:" $$missing >&2; \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update -qq && apt-get install -y -qq $$missing >/dev/null || { echo "make deps: apt-get failed (run as root)" >&2; exit 1; }; \
	fi

test: deps
	@$(MAKE) --no-print-directory $(BUILD)/voxlab $(UNIT_BIN) $(PYLIB)
	@BUILD=$(BUILD) tests/run_all.sh

test-asan:
	@$(MAKE) --no-print-directory SANITIZE=1 test

# Every libFuzzer harness and the experiment-declaration mutation loop for FUZZ_SECONDS each
# (tests/fuzz/run.sh); reproducers of any crash in build/fuzz/crashes/.
fuzz:
	@$(MAKE) --no-print-directory deps EXTRA_DEPS="$(FUZZ_DEPS)"
	@$(MAKE) --no-print-directory build/voxlab
	@$(MAKE) --no-print-directory SANITIZE=fuzz fuzz-build
	@FUZZ_SECONDS=$(FUZZ_SECONDS) FUZZ_BUILD=build-fuzz VOXLAB=$(CURDIR)/build/voxlab tests/fuzz/run.sh

fuzz-build: $(FUZZ_BIN)

bench: deps bench-build
	@BUILD=$(BUILD) tests/bench.sh

# The benchmark programs alone (CI builds them so that they cannot rot unnoticed).
bench-build:
	@$(MAKE) --no-print-directory $(BUILD)/voxlab $(BENCH_BIN)

# The main job on the built-in `spheres` scene: ground truth, every registered model baked and
# rendered at 64^3, each compared with the truth; a table and a side-by-side strip in results/demo/.
# A declaration (experiments/demo.json) run by the same engine as table1 and pareto (cached jobs).
demo: deps
	@$(MAKE) --no-print-directory $(BUILD)/voxlab
	/usr/bin/python3 experiments/demo.py --voxlab $(BUILD)/voxlab $(if $(filter 1,$(FRESH)),--force)
	@cat results/demo/table.md
	@echo "demo: images, table.md and strip_64.png are in results/demo/"

clean:
	rm -rf build build-asan build-fuzz

# Experiment targets (table1, pareto, figures, dashboard, regress) live beside their scripts.
include experiments/experiments.mk

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
