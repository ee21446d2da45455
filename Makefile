# PDS - photon differential splatting. Plain make, plain cc, C99.
#   make            build ./pds
#   make render     render the demo scene to demo.png
#   make test       build and run the tests (last line: "N passed, N failed")
#   make sanitize   the same tests built with AddressSanitizer + UBSan
#   make bench      benchmarks (figures, not pass/fail)
#   make update-golden  re-render tests/golden/*.pfm (review with git diff)
#   make fuzz       libFuzzer on the scene, OBJ, MTL, PFM, partial-file and OpenEXR readers
#                   (clang; FUZZ_SECONDS per target, default 60; -j2 runs two
#                   at once); make fuzz-regress replays the committed corpus
#   make references     reference images of the shipped scenes (minutes)
#   make gallery        the README gallery: every scene at full size (minutes)
#   make core       the small core (-DPDS_CORE: no PNG/EXR, baselines, gi, isc, sky, spectral,
#                   partial files, benchmarks):
#                   its line count, its build and its tests (README "A small core")
#   make windows    MinGW-w64 cross-build: pds.exe and tests/test_pds.exe;
#                   make windows-test runs the tests under wine (README "Windows")
#   make msvc-check compiles the MSVC code paths with clang's MSVC target
#   make povray-compare  PDS, pm and POV-Ray (if installed) at equal CPU time on
#                   scenes/ball.scene against tests/ref_ball, an independent
#                   exact-sphere reference (README "PDS against POV-Ray"; minutes)
#   make CC=clang   any C99 compiler works
CC ?= cc
OPT ?= -O2
WARN = -std=c99 -pedantic -Wall -Wextra
CFLAGS ?= $(OPT)
LDLIBS = -lm -lpthread
SAN = -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all $(SAN_EXTRA)
# clang adds more checks: make sanitize CC=clang SAN_EXTRA="$(CLANG_SAN)"
# (unsigned wrap-around and unsigned left shifts that drop high bits are
# defined behaviour; the hashes, the RNG, the BVH's masks and the Morton
# codes rely on them)
CLANG_SAN = -fsanitize=float-cast-overflow,integer -fno-sanitize=unsigned-integer-overflow,unsigned-shift-base

TEST_SRC = tests/test_main.c tests/runner.h $(wildcard tests/test_*.c)

all: pds

pds: main.c pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -o $@ main.c pds.c $(LDLIBS)

tests/test_pds: $(TEST_SRC) pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -I. -o $@ tests/test_main.c $(LDLIBS)

test: pds tests/test_pds
	PDS_BIN=./pds ./tests/test_pds

pds-san: main.c pds.c pds.h
	$(CC) $(WARN) $(SAN) -o $@ main.c pds.c $(LDLIBS)

tests/test_pds-san: $(TEST_SRC) pds.c pds.h
	$(CC) $(WARN) $(SAN) -I. -o $@ tests/test_main.c $(LDLIBS)

sanitize: pds-san tests/test_pds-san
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 PDS_BIN=./pds-san ./tests/test_pds-san

update-golden: tests/test_pds
	PDS_UPDATE_GOLDEN=1 ./tests/test_pds golden_images

# Reference images of the shipped scenes for `pds sweep` and `pds race`,
# stored next to the scenes (minutes on 2 cores; not part of `make test`).
# Each reference has 64 samples a pixel and its own seed (1000): its eye
# samples are not those of the renders it judges (seed 0 by default).
# The case studies are lit by collimated light, which a path tracer cannot
# render through glass or metal. The refraction case's camera sees its
# floor directly, so its caustics-only reference is light traced
# (tests/ref_light: no density kernel, 1.5 x 10^9 photons, a quarter of an
# hour); the reflection case's camera also sees the floor in the ring's
# metal, which light tracing cannot, so its reference is progressive
# photon mapping with 64 x 4M photons from a radius of 0.001 (a quarter of
# a pixel on the floor; a few minutes). The gold ring's come from path tracing; the glass
# bunny's (a scanned mesh, fetched) from ppm with 64 x 2M photons and 512
# samples a pixel (7 minutes, 5.2 GB: its pixels seen through the glass
# need the samples, its floor the photons). The ring
# and octahedron (a point light) gets ppm with 64 x 2M photons at its full
# 512 x 512 and 16 samples a pixel, the image-space caustics' benchmark
# size (21 minutes on a busy machine); the cognac glass ppm with 64 x 2M
# photons from a radius of half a pixel on the table (11 minutes; a
# 24 x 1M-photon render from radius 0.02 differs from it by RMSE 0.0013);
# Newton's prism (spectral) ppm with 40 x 1M photons at 240 x 160, seed
# 1001 (about a minute). The Cornell box, the demo and the embedded torus
# get ppm from a third of a pixel or less with 16 samples a pixel and
# 400-800 million photons (5-8 minutes each): ppm's automatic radius,
# which a 40-second render starts from, blurs their caustics by more
# than the methods' errors differ.
references: pds tests/ref_light
	tests/ref_light scenes/refraction.scene --photons 1500000000 --res 256x256 --seed 1000 \
	  -o scenes/refraction.ref.pfm
	./pds render scenes/reflection.scene --method ppm --caustics-only --photons 4000000 --passes 64 \
	  --radius 0.001 --res 256x256 --spp 64 --seed 1003 --quiet -o scenes/reflection.ref.pfm
	./pds render scenes/ring_octahedron.scene --method ppm --caustics-only --photons 2000000 --passes 64 \
	  --radius 0.008 --spp 16 --seed 1000 --quiet -o scenes/ring_octahedron.ref.pfm
	./pds render scenes/cardioid.scene --method pt --spp 4096 --res 256x192 --quiet -o scenes/cardioid.ref.pfm
	./pds render scenes/cardioid.scene --method pt --caustics-only --spp 4096 --res 256x192 --quiet \
	  -o scenes/cardioid.caustics.ref.pfm
	./pds render scenes/cognac.scene --method ppm --caustics-only --photons 2000000 --passes 64 \
	  --radius 0.01 --res 256x256 --spp 64 --seed 1000 --quiet -o scenes/cognac.caustics.ref.pfm
	./pds render scenes/prism.scene --method ppm --caustics-only --photons 1000000 --passes 40 \
	  --radius 0.004 --res 240x160 --spp 64 --seed 1001 --quiet -o scenes/prism.caustics.ref.pfm
	./pds render scenes/cornell.scene --method ppm --caustics-only --photons 2000000 --passes 400 \
	  --radius 0.02 --res 256x256 --spp 16 --seed 1000 --quiet -o scenes/cornell.caustics.ref.pfm
	./pds render scenes/demo.scene --method ppm --caustics-only --photons 2000000 --passes 400 \
	  --radius 0.004 --res 256x192 --spp 16 --seed 1000 --quiet -o scenes/demo.caustics.ref.pfm
	./pds render scenes/torus.scene --method ppm --caustics-only --photons 2000000 --passes 200 \
	  --radius 0.004 --res 256x256 --spp 16 --seed 1000 --quiet -o scenes/torus.caustics.ref.pfm
	$(MAKE) $(BUNNY)
	./pds render scenes/bunny.scene --method ppm --caustics-only --photons 2000000 --passes 64 \
	  --radius 0.01 --res 256x256 --spp 512 --seed 1000 --quiet -o scenes/bunny.caustics.ref.pfm

# The README's gallery: every shipped scene at full size with PDS and the
# options its README line recommends, and PDS beside pm on equal photon-pass
# time for the refraction case, the gold ring, the pool and the prism
# (about 3 minutes).
GALLERY = scenes/gallery
gallery: pds
	mkdir -p $(GALLERY)
	./pds render scenes/demo.scene -o $(GALLERY)/demo.png
	./pds render scenes/refraction.scene --photons 200000 --smoothing 8 -o $(GALLERY)/refraction.png
	./pds render scenes/reflection.scene --photons 200000 --smoothing 8 -o $(GALLERY)/reflection.png
	./pds render scenes/cardioid.scene --photons 200000 --smoothing 8 -o $(GALLERY)/cardioid.png
	./pds render scenes/cognac.scene --smoothing 8 -o $(GALLERY)/cognac.png
	./pds render scenes/pool.scene --photons 400000 --smoothing 8 -o $(GALLERY)/pool.png
	./pds render scenes/torus.scene --photons 400000 --smoothing 8 -o $(GALLERY)/torus.png
	./pds render scenes/cornell.scene --photons 400000 --smoothing 8 -o $(GALLERY)/cornell.png
	./pds render scenes/ring_octahedron.scene --photons 400000 --smoothing 8 -o $(GALLERY)/ring_octahedron.png
	./pds render scenes/prism.scene --photons 1000000 -o $(GALLERY)/prism.png
	./pds render scenes/gem.scene --photons 1000000 -o $(GALLERY)/gem.png
	./pds render scenes/glossy.scene --method gi -o $(GALLERY)/glossy.png
	./pds render scenes/refraction.scene --smoothing 8 --time 6 -o $(GALLERY)/refraction.pds-6s.png
	./pds render scenes/refraction.scene --method pm --k 50 --time 6 -o $(GALLERY)/refraction.pm-6s.png
	./pds render scenes/cardioid.scene --smoothing 8 --time 4 -o $(GALLERY)/cardioid.pds-4s.png
	./pds render scenes/cardioid.scene --method pm --k 50 --time 4 -o $(GALLERY)/cardioid.pm-4s.png
	./pds render scenes/pool.scene --smoothing 8 --time 6 -o $(GALLERY)/pool.pds-6s.png
	./pds render scenes/pool.scene --method pm --k 50 --max-radius 0.1 --time 6 -o $(GALLERY)/pool.pm-6s.png
	./pds render scenes/prism.scene --time 8 -o $(GALLERY)/prism.pds-8s.png
	./pds render scenes/prism.scene --method pm --k 50 --max-radius 0.02 --time 8 -o $(GALLERY)/prism.pm-8s.png

render: pds
	./pds render scenes/demo.scene -o demo.png

# The POV-Ray comparison (README "PDS against POV-Ray"): tests/ref_ball is
# an independent reference of scenes/ball.scene (no pds code: an exact
# sphere, light tracing into a floor grid, both Fresnel branches at the
# eye); tests/ball_metrics measures images against it (pds.c only reads
# the images). Neither is part of the library or of make test.
tests/ref_ball: tests/ref_ball.c
	$(CC) $(WARN) $(CFLAGS) -o $@ tests/ref_ball.c $(LDLIBS)

tests/ref_light: tests/ref_light.c pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -I. -o $@ tests/ref_light.c $(LDLIBS)

# A long path-traced reference of a window of pixels, seed by seed (README
# "Global illumination: --method gi", the agreement test's blocks); it
# includes pds.c, as the tests do, to render exactly pt's pixels.
tests/ref_region: tests/ref_region.c pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -I. -o $@ tests/ref_region.c $(LDLIBS)

tests/ball_metrics: tests/ball_metrics.c pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -I. -o $@ tests/ball_metrics.c pds.c $(LDLIBS)

povray-compare: pds tests/ref_ball tests/ball_metrics
	sh tests/povray_compare.sh

# The small core (README "A small core"): pds.c without the PNG and
# OpenEXR coders, the baselines, gi, isc, the environment light, spectral
# rendering, the partial file and the benchmarks. Prints the non-blank
# lines of pds.c a reader of it reads (tests/core_lines.sh), builds the
# tool and the core's tests, runs them, and checks that each switch alone
# also builds without a warning (about a minute of CPU in all).
CORE_SWITCHES = -DPDS_NO_PNG -DPDS_NO_BASELINES -DPDS_NO_BENCH -DPDS_NO_MTL -DPDS_NO_GI -DPDS_NO_ISC -DPDS_NO_ENV \
  -DPDS_NO_SPECTRAL -DPDS_NO_PARTIAL_FILE
CORE_CHECKS = $(CORE_SWITCHES:-D%=core-check-%)
core: pds-core tests/test_core $(CORE_CHECKS)
	CC="$(CC)" sh tests/core_lines.sh -DPDS_CORE
	./tests/test_core

# pds.c compiled with one switch alone; one target each, so that make -j
# compiles them side by side
$(CORE_CHECKS): core-check-%: pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -D$* -c -o /dev/null pds.c

pds-core: main.c pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -DPDS_CORE -o $@ main.c pds.c $(LDLIBS)

tests/test_core: tests/test_core.c $(TEST_SRC) pds.c pds.h
	$(CC) $(WARN) $(CFLAGS) -DPDS_CORE -I. -o $@ tests/test_core.c $(LDLIBS)

# Windows (README "Windows"): cross-compiled with MinGW-w64 (Debian:
# gcc-mingw-w64-x86-64), Win32 threads, no extra library. windows-test
# runs the test program under wine (Debian: wine64) in a private wine
# prefix under tests/out, then renders a scene with pds.exe and with ./pds
# and requires the two images to be the same bit for bit.
MINGW_CC ?= x86_64-w64-mingw32-gcc
WINE ?= $(shell command -v wine64 2>/dev/null || ls /usr/lib/wine/wine64 2>/dev/null)
WINE_ENV = WINEPREFIX=$(CURDIR)/tests/out/wine WINEDEBUG=-all
WINESERVER ?= $(shell command -v wineserver 2>/dev/null || ls /usr/lib/wine/wineserver64 2>/dev/null)
windows: pds.exe tests/test_pds.exe

pds.exe: main.c pds.c pds.h
	$(MINGW_CC) $(WARN) $(CFLAGS) -o $@ main.c pds.c

tests/test_pds.exe: $(TEST_SRC) pds.c pds.h
	$(MINGW_CC) $(WARN) $(CFLAGS) -I. -o $@ tests/test_main.c

# One wine server for the step's two programs, kept until the step ends
# (-p): a server that is shutting down after the first program's end can
# drop the second's connection ("wine client error: recvmsg: Connection
# reset by peer", seen once in CI on 6 December 2026).
windows-test: windows pds
	@test -n "$(WINE)" || { echo "windows-test needs wine (Debian: apt-get install wine64)"; exit 1; }
	@test -n "$(WINESERVER)" || { echo "windows-test needs wineserver (Debian: apt-get install wine64)"; exit 1; }
	mkdir -p tests/out/wine
	$(WINE_ENV) $(WINESERVER) -p
	$(WINE_ENV) $(WINE) tests/test_pds.exe || { $(WINE_ENV) $(WINESERVER) -k; exit 1; }
	$(WINE_ENV) $(WINE) ./pds.exe render scenes/teaching_mirror.scene --caustics-only --quiet -o tests/out/wine-mirror.pfm || \
	  { $(WINE_ENV) $(WINESERVER) -k; exit 1; }
	$(WINE_ENV) $(WINESERVER) -k
	./pds render scenes/teaching_mirror.scene --caustics-only --quiet -o tests/out/linux-mirror.pfm
	tests/pfm_pixels.sh tests/out/wine-mirror.pfm > tests/out/wine-mirror.px
	tests/pfm_pixels.sh tests/out/linux-mirror.pfm > tests/out/linux-mirror.px
	cmp tests/out/wine-mirror.px tests/out/linux-mirror.px && echo "windows-test: pds.exe and pds render the same pixels, bit for bit"

# MSVC (README "Windows"): there is no MSVC here, so clang compiles
# pds.c, main.c and the test program as MSVC would see them (target
# x86_64-pc-windows-msvc: _WIN32 and _MSC_VER defined, no __GNUC__, the
# Microsoft ABI; warnings are errors, and so are variable-length arrays,
# which MSVC lacks) against MinGW-w64's headers, to COFF
# objects that are not linked or run. Two concessions to those headers:
# _MSC_VER is 1100, so that they leave out the trailing __declspec
# attributes clang refuses, and empty x86intrin.h and emmintrin.h come
# first, as the headers #define __attribute__ away before they include
# clang's intrinsics (PDS uses none). Some 20 s of CPU.
MSVC_CHECK_CC ?= clang
MSVC_SHIM = tests/out/msvc-shim
MSVC_FLAGS = --target=x86_64-pc-windows-msvc -fms-compatibility-version=11.0 $(WARN) -Wvla -Werror -O1 \
  -I$(MSVC_SHIM) -I. -isystem /usr/x86_64-w64-mingw32/include
msvc-check:
	mkdir -p $(MSVC_SHIM)
	: > $(MSVC_SHIM)/x86intrin.h
	: > $(MSVC_SHIM)/emmintrin.h
	for f in pds.c main.c tests/test_main.c; do $(MSVC_CHECK_CC) $(MSVC_FLAGS) -c -o $(MSVC_SHIM)/out.obj $$f || exit 1; done
	@echo "msvc-check: pds.c, main.c and tests/test_main.c compile for x86_64-pc-windows-msvc"

# A real scanned mesh for `pds bench rays`: the Stanford bunny as Debian's
# glmark2-data package ships it (69,666 triangles). It is fetched, not
# vendored: it is not part of PDS and carries that package's licence.
BENCH_DIR = tests/out/bench
BUNNY = $(BENCH_DIR)/bunny.obj

$(BUNNY):
	mkdir -p $(BENCH_DIR)
	cd $(BENCH_DIR) && apt-get download glmark2-data && dpkg-deb -x glmark2-data_*.deb pkg && \
	  cp pkg/usr/share/glmark2/models/bunny.obj bunny.obj && rm -rf pkg glmark2-data_*.deb

# scenes/bunny.scene needs the mesh: make bunny
bunny: $(BUNNY)

bench: pds $(BUNNY)
	./pds bench rays $(BUNNY) 4000000
	./pds bench pt
	./pds bench pass scenes/*.scene

# Fuzzing (README "Fuzzing"): one libFuzzer harness per reader in
# tests/fuzz/, built with clang and every sanitizer that applies. All of
# -fsanitize=integer is on except unsigned-integer-overflow: unsigned
# arithmetic wraps by definition, and pds.c relies on it on purpose (the
# FNV-1a and splitmix hashes, the random numbers, the BVH traversal's
# branch-free swap mask 0u - (d1 < d0)). Signed overflow, shifts, division
# by zero and value-changing implicit conversions stay checked.
FUZZ_SECONDS ?= 60
FUZZ_CC ?= clang
FUZZ_OUT = tests/out/fuzz
FUZZ_TARGETS = scene obj mtl pfm partial exr
FUZZ_CFLAGS = $(WARN) -g -O1 -fsanitize=fuzzer,address,undefined,float-cast-overflow,integer \
  -fno-sanitize=unsigned-integer-overflow -fno-sanitize-recover=all

# One program holds every harness (tests/fuzz/fuzz_all.c: pds.c built
# once with the sanitizers, not six times); fuzz_TARGET is a link to it
# and runs as that target's harness.
$(FUZZ_OUT)/fuzz_all: tests/fuzz/fuzz_all.c $(FUZZ_TARGETS:%=tests/fuzz/fuzz_%.c) tests/fuzz/fuzz.h pds.c pds.h
	mkdir -p $(FUZZ_OUT)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -o $@ tests/fuzz/fuzz_all.c $(LDLIBS)

$(FUZZ_TARGETS:%=$(FUZZ_OUT)/fuzz_%): $(FUZZ_OUT)/fuzz_all
	ln -sf fuzz_all $@

$(FUZZ_TARGETS:%=fuzz-%): fuzz-%: $(FUZZ_OUT)/fuzz_%
	sh tests/fuzz/run.sh $* $(FUZZ_SECONDS)

fuzz: $(FUZZ_TARGETS:%=fuzz-%)

fuzz-regress: $(FUZZ_TARGETS:%=$(FUZZ_OUT)/fuzz_%)
	for t in $(FUZZ_TARGETS); do sh tests/fuzz/run.sh $$t 0 || exit 1; done

clean:
	rm -f pds pds-san pds-core pds.exe tests/test_pds tests/test_pds-san tests/test_core tests/test_pds.exe demo.png \
	  tests/ref_ball tests/ball_metrics tests/ref_light tests/ref_region
	rm -rf tests/out

.PHONY: all test sanitize render bench bunny clean update-golden references gallery fuzz fuzz-regress core windows \
  povray-compare $(CORE_CHECKS) \
  windows-test msvc-check \
  $(FUZZ_TARGETS:%=fuzz-%)
