# plsr: two commands do everything on a fresh Debian 12 machine with Rust.
#   make demo   installs missing packages, builds, renders the default scene
#   make test   installs missing packages, builds, runs every test
# Both install the Debian packages plsr needs (as root, or through sudo).

SHELL := /bin/bash
CARGO ?= cargo
DEB_PACKAGES := libembree-dev libopenimageio-dev libclang-dev clang pkg-config valgrind cmake slurm-wlm munge
# Embree's own pathtracer, the peer of `plsr bench` (optional at run time).
DEB_BENCH_PACKAGES := embree-tools
DEMO_SCENE := assets/scenes/pls-room/pls-room.toml
OUT := out

.PHONY: demo test paper fuzz deps bench-deps bench build fmt clippy install-deps-if-missing header install

demo: deps
	$(CARGO) build --release
	mkdir -p $(OUT)
	./target/release/plsr render $(DEMO_SCENE) -o $(OUT)/demo.exr --png $(OUT)/demo.png
	@echo "wrote $(OUT)/demo.exr and $(OUT)/demo.png"

test: deps
	$(CARGO) test --workspace --no-fail-fast

# The paper's experiment redone on a synthetic room (docs/paper-experiment.md):
# ground-truth photos, PLS lights and an HDR panorama, composites, CW-SSIM,
# LPIPS and FLIP; about 12 minutes on two cores. Writes $(OUT)/paper/
# (results.md, results.json, figure.png), replacing an earlier run.
# `plsr experiment paper --quick` runs it small (and is part of `make test`).
paper: deps
	$(CARGO) build --release
	rm -rf $(OUT)/paper
	./target/release/plsr experiment paper -o $(OUT)/paper

# Searches further than `make test`'s fixed-seed fuzzing: fresh seeds, more
# cases (FUZZ_CASES per parser). Failures are shrunk and their seeds kept in
# tests/fuzz_parsers.proptest-regressions.
FUZZ_CASES ?= 20000
fuzz: deps
	PLSR_FUZZ_SEED=random PLSR_FUZZ_CASES=$(FUZZ_CASES) PLSR_FUZZ_TRACE=$(CURDIR)/target/fuzz-case.txt \
		$(CARGO) test --test fuzz_parsers -- --nocapture

build: deps
	$(CARGO) build --release

bench: deps bench-deps
	$(CARGO) build --release
	./target/release/plsr bench

# Installs the Debian packages that are missing (apt-get update once, only
# when something must be installed).
deps:
	@bash scripts/install-deps.sh $(DEB_PACKAGES)

bench-deps:
	@bash scripts/install-deps.sh $(DEB_BENCH_PACKAGES)

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --workspace --all-targets -- -D warnings

# Regenerates the C header include/plsr.h from src/capi/ (pinned cbindgen).
header:
	PLSR_WRITE_HEADER=1 $(CARGO) test --test capi_header

# Installs the C ABI: libplsr.so (without debug info), libplsr.a, plsr.h, plsr.hpp, plsr.pc and a
# CMake package file under PREFIX (default /usr/local).
PREFIX ?= /usr/local
CARGO_TARGET_DIR ?= target
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
install: deps
	CARGO_TARGET_DIR=$(CARGO_TARGET_DIR) $(CARGO) build --release --lib
	install -d $(DESTDIR)$(PREFIX)/lib/pkgconfig $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib/cmake/plsr
	install -m 755 $(CARGO_TARGET_DIR)/release/libplsr.so $(DESTDIR)$(PREFIX)/lib/
	strip --strip-debug $(DESTDIR)$(PREFIX)/lib/libplsr.so
	install -m 644 $(CARGO_TARGET_DIR)/release/libplsr.a $(DESTDIR)$(PREFIX)/lib/
	install -m 644 include/plsr.h include/plsr.hpp $(DESTDIR)$(PREFIX)/include/
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|$(VERSION)|' plsr.pc.in > $(DESTDIR)$(PREFIX)/lib/pkgconfig/plsr.pc
	sed -e 's|@VERSION@|$(VERSION)|' plsrConfig.cmake.in > $(DESTDIR)$(PREFIX)/lib/cmake/plsr/plsrConfig.cmake
	@echo "installed plsr $(VERSION) under $(DESTDIR)$(PREFIX)"
