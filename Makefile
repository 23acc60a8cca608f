# plsr: two commands do everything on a fresh Debian 12 machine with Rust.
#   make demo   installs missing packages, builds, renders the default scene
#   make test   installs missing packages, builds, runs every test
# Both install the Debian packages plsr needs (as root, or through sudo).

SHELL := /bin/bash
CARGO ?= cargo
# What building plsr needs (`make demo`, `build`, `install`, `paper`, `bench`).
DEB_PACKAGES := libembree-dev libopenimageio-dev libclang-dev clang pkg-config
# What the tests need besides: valgrind and cmake for the C hosts, Slurm
# and munge for the farm's single-node cluster (`make test`, `fuzz`).
DEB_TEST_PACKAGES := valgrind cmake slurm-wlm munge
# Embree's own pathtracer, the peer of `plsr bench` (optional at run time).
DEB_BENCH_PACKAGES := embree-tools
DEMO_SCENE := assets/scenes/pls-room/pls-room.toml
OUT := out

.PHONY: demo test paper fuzz fuzz-coverage deps test-deps bench-deps bench build fmt clippy install-deps-if-missing header install uninstall

demo: deps
	$(CARGO) build --release
	mkdir -p $(OUT)
	./target/release/plsr render $(DEMO_SCENE) -o $(OUT)/demo.exr --png $(OUT)/demo.png
	@echo "wrote $(OUT)/demo.exr and $(OUT)/demo.png"

# Then every fuzz target runs for FUZZ_TEST_SECONDS from its seeds, with
# a fixed libFuzzer seed (docs/fuzzing.md).
FUZZ_TEST_SECONDS ?= 20
test: test-deps
	$(CARGO) test --workspace --no-fail-fast
	PLSR_FUZZ_ARGS=-seed=1 bash scripts/fuzz.sh all $(FUZZ_TEST_SECONDS)

# The paper's experiment redone on a synthetic room (docs/paper-experiment.md):
# ground-truth photos, PLS lights (measured, and fitted from the photos) and
# an HDR panorama, composites, CW-SSIM, LPIPS and FLIP; about 20 minutes on
# two cores. Writes $(OUT)/paper/ (results.md, results.json, figure.png),
# replacing an earlier run.
# `plsr experiment paper --quick` runs it small (and is part of `make test`).
paper: deps
	$(CARGO) build --release
	rm -rf $(OUT)/paper
	./target/release/plsr experiment paper -o $(OUT)/paper

# Searches further than `make test`'s fixed-seed proptest fuzzing: fresh
# seeds, more cases (FUZZ_CASES per parser). Failures are shrunk and their seeds kept in
# tests/it/fuzz_parsers.proptest-regressions.
FUZZ_CASES ?= 20000
fuzz: test-deps
	PLSR_FUZZ_SEED=random PLSR_FUZZ_CASES=$(FUZZ_CASES) PLSR_FUZZ_TRACE=$(CURDIR)/target/fuzz-case.txt \
		$(CARGO) test -p plsr --test it fuzz_parsers:: -- --nocapture

# Coverage-guided fuzzing with libFuzzer (docs/fuzzing.md): every target
# of fuzz/ for FUZZ_SECONDS each, from the committed seeds and the corpus
# earlier runs kept (target/fuzz/corpus/); prints coverage and executions.
FUZZ_SECONDS ?= 300
fuzz-coverage: test-deps
	bash scripts/fuzz.sh all $(FUZZ_SECONDS)

build: deps
	$(CARGO) build --release

bench: deps bench-deps
	$(CARGO) build --release
	./target/release/plsr bench

# Installs the Debian packages that are missing (apt-get update once, only
# when something must be installed).
deps:
	@bash scripts/install-deps.sh $(DEB_PACKAGES)

test-deps:
	@bash scripts/install-deps.sh $(DEB_PACKAGES) $(DEB_TEST_PACKAGES)

bench-deps:
	@bash scripts/install-deps.sh $(DEB_BENCH_PACKAGES)

fmt:
	$(CARGO) fmt --all

clippy: deps
	$(CARGO) clippy --workspace --all-targets -- -D warnings

# Regenerates the C header include/plsr.h from crates/capi/ (pinned cbindgen).
header:
	PLSR_WRITE_HEADER=1 $(CARGO) test -p plsr-capi --lib tests::header

# Installs the C ABI and the program (README, "From C and C++"):
# libplsr.so.X.Y.Z (stripped; soname libplsr.so.X, debug info in
# LIBDIR/.debug/), libplsr.a, plsr.h, plsr.hpp, plsr.pc, the CMake package
# (plsrConfig.cmake, plsrConfigVersion.cmake) and the `plsr` program.
#   make install PREFIX=$HOME/.local
#   make install PREFIX=/usr LIBDIR=/usr/lib/$(gcc -print-multiarch)   (Debian's multiarch folder)
#   make install DESTDIR=/tmp/stage PREFIX=/usr                           (staged, for packaging)
# `make uninstall` with the same PREFIX, LIBDIR and DESTDIR removes what it
# installed (listed in LIBDIR/plsr/install-manifest.txt) and the folders it made.
PREFIX ?= /usr/local
LIBDIR ?= $(PREFIX)/lib
BINDIR ?= $(PREFIX)/bin
INCLUDEDIR ?= $(PREFIX)/include
DESTDIR ?=
CARGO_TARGET_DIR ?= target
# The cargo profile `make install` builds and installs (release); its folder
# under CARGO_TARGET_DIR is cargo's (debug for dev and test, release for bench).
CARGO_PROFILE ?= release
PROFILE_DIR := $(if $(filter dev test,$(CARGO_PROFILE)),debug,$(if $(filter bench,$(CARGO_PROFILE)),release,$(CARGO_PROFILE)))
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
# The oldest version whose C ABI this one keeps (0.2.0 last changed a struct,
# plsr_principled); find_package(plsr X.Y) accepts requests from it up to VERSION.
ABI_SINCE := 0.2.0
# INSTALL_FROM: a folder that already holds libplsr.so, libplsr.a and plsr;
# `make install` then installs those and builds nothing (the C ABI's tests
# install what `cargo test` built this way).
INSTALL_FROM ?=
INSTALL_ENV = PREFIX="$(PREFIX)" LIBDIR="$(LIBDIR)" BINDIR="$(BINDIR)" INCLUDEDIR="$(INCLUDEDIR)" \
	DESTDIR="$(DESTDIR)" VERSION="$(VERSION)" ABI_SINCE="$(ABI_SINCE)" \
	TARGET="$(or $(INSTALL_FROM),$(CARGO_TARGET_DIR)/$(PROFILE_DIR))"
install: deps
ifeq ($(INSTALL_FROM),)
	CARGO_TARGET_DIR=$(CARGO_TARGET_DIR) $(CARGO) build --profile $(CARGO_PROFILE) -p plsr-capi -p plsr-cli
endif
	$(INSTALL_ENV) bash scripts/install.sh install

uninstall:
	$(INSTALL_ENV) bash scripts/install.sh uninstall
