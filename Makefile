# PDS - photon differential splatting. Plain make, plain cc, C99.
#   make            build ./pds
#   make render     render the demo scene to demo.png
#   make test       build and run the tests (last line: "N passed, N failed")
#   make sanitize   the same tests built with AddressSanitizer + UBSan
#   make bench      benchmarks (figures, not pass/fail)
#   make update-golden  re-render tests/golden/*.pfm (review with git diff)
#   make references     reference images of the shipped scenes (minutes)
#   make CC=clang   any C99 compiler works
CC ?= cc
OPT ?= -O2
WARN = -std=c99 -pedantic -Wall -Wextra
CFLAGS ?= $(OPT)
LDLIBS = -lm -lpthread
SAN = -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined

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
# The case studies are lit by collimated light, which a path tracer cannot
# render through glass or metal: their caustics-only references are
# progressive photon mapping with 32 x 1M photons from a small initial
# radius (0.004, about a pixel on the floor), as the paper used 10M-photon
# photon mapping. The gold ring's come from path tracing.
references: pds
	./pds render scenes/refraction.scene --method ppm --caustics-only --photons 1000000 --passes 32 \
	  --radius 0.004 --res 256x256 --spp 4 --quiet -o scenes/refraction.ref.pfm
	./pds render scenes/reflection.scene --method ppm --caustics-only --photons 1000000 --passes 32 \
	  --radius 0.004 --res 256x256 --spp 4 --quiet -o scenes/reflection.ref.pfm
	./pds render scenes/cardioid.scene --method pt --spp 4096 --res 256x192 --quiet -o scenes/cardioid.ref.pfm
	./pds render scenes/cardioid.scene --method pt --caustics-only --spp 4096 --res 256x192 --quiet \
	  -o scenes/cardioid.caustics.ref.pfm

render: pds
	./pds render scenes/demo.scene -o demo.png

# A real scanned mesh for `pds bench rays`: the Stanford bunny as Debian's
# glmark2-data package ships it (69,666 triangles). It is fetched, not
# vendored: it is not part of PDS and carries that package's licence.
BENCH_DIR = tests/out/bench
BUNNY = $(BENCH_DIR)/bunny.obj

$(BUNNY):
	mkdir -p $(BENCH_DIR)
	cd $(BENCH_DIR) && apt-get download glmark2-data && dpkg-deb -x glmark2-data_*.deb pkg && \
	  cp pkg/usr/share/glmark2/models/bunny.obj bunny.obj && rm -rf pkg glmark2-data_*.deb

bench: pds $(BUNNY)
	./pds bench rays $(BUNNY) 4000000
	./pds bench pt

clean:
	rm -f pds pds-san tests/test_pds tests/test_pds-san demo.png
	rm -rf tests/out

.PHONY: all test sanitize render bench clean update-golden references
