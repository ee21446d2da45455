#!/usr/bin/env bash
# tests/check_exr_oiio.sh - the OpenEXR files pds writes, read by another
# program: OpenImageIO's oiiotool (Debian: openimageio-tools). Checks that
# oiiotool sees float R, G, B with the compression asked for and the
# render's metadata (pds:kind, pds:method, ...); that its pixel values are
# those of the same render written as PFM (with its metadata trailer),
# value for value at 9 digits, for ZIP and uncompressed files, and those
# `pds pixel` prints; and that pds reads the half-float ZIP file oiiotool
# makes of it.
#
#   tests/check_exr_oiio.sh            exit 77 (skipped, saying why) without oiiotool
#   tests/check_exr_oiio.sh --install  apt-get install openimageio-tools first if missing
#
# Some 5 s (three 32x24 renders); every oiiotool call is limited to 60 s.
# Builds ./pds if needed; writes only under a temporary folder.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v oiiotool >/dev/null 2>&1 && [ "${1:-}" = "--install" ]; then
    echo "check_exr_oiio: installing openimageio-tools"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        openimageio-tools >/dev/null || true
fi
if ! command -v oiiotool >/dev/null 2>&1; then
    echo "check_exr_oiio: SKIP: no oiiotool (apt-get install openimageio-tools, or run with --install)"
    exit 77
fi

[ -x ./pds ] || make pds >/dev/null
tmp=$(mktemp -d /tmp/pds_check_exr_oiio.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
oiio() { timeout 60 oiiotool "$@"; }

render="render scenes/teaching_mirror.scene --caustics-only --res 32x24 --spp 2 --photons 20000 --seed 5 --quiet"
./pds $render -o "$tmp/zip.exr" >/dev/null
./pds $render -o "$tmp/none.exr" --exr-compression none >/dev/null
./pds $render -o "$tmp/same.pfm" >/dev/null

fail=0
check() { if ! eval "$2"; then echo "check_exr_oiio: FAIL: $1"; fail=1; fi; }

oiio --info -v "$tmp/zip.exr" >"$tmp/zip.info"
oiio --info -v "$tmp/none.exr" >"$tmp/none.info"
check "oiiotool sees a 32 x 24 float OpenEXR" "grep -q '32 x   24, 3 channel, float openexr' '$tmp/zip.info'"
check "channels R, G, B" "grep -q 'channel list: R, G, B' '$tmp/zip.info'"
check "ZIP compression" "grep -q 'compression: \"zip\"' '$tmp/zip.info'"
check "no compression" "grep -q 'compression: \"none\"' '$tmp/none.info'"
check "metadata pds:kind" "grep -q 'pds:kind: \"caustics-only\"' '$tmp/zip.info'"
check "metadata pds:method" "grep -q 'pds:method: \"pds\"' '$tmp/zip.info'"
check "metadata pds:seed" "grep -q 'pds:seed: \"5\"' '$tmp/zip.info'"
check "metadata pds:photons, options, time, version" \
    "grep -q 'pds:photons:' '$tmp/zip.info' && grep -q 'pds:options: \"paths=caustics-only' '$tmp/zip.info' &&
     grep -q 'pds:time: \"total=' '$tmp/zip.info' && grep -q 'pds:version:' '$tmp/zip.info'"

# every pixel, as oiiotool prints it, the same in the three files
for f in zip.exr none.exr same.pfm; do oiio --dumpdata "$tmp/$f" | tail -n +2 >"$tmp/$f.dump"; done
check "768 pixels dumped" "[ \$(wc -l <'$tmp/zip.exr.dump') = 768 ]"
check "ZIP EXR = PFM, value for value" "cmp -s '$tmp/zip.exr.dump' '$tmp/same.pfm.dump'"
check "uncompressed EXR = PFM, value for value" "cmp -s '$tmp/none.exr.dump' '$tmp/same.pfm.dump'"
# one pixel against pds's own reading (6 digits)
ours=$(./pds pixel "$tmp/zip.exr" 17 11 | sed 's/.* r=\([^ ]*\) g=\([^ ]*\) b=\([^ ]*\)$/\1 \2 \3/')
theirs=$(grep 'Pixel (17, 11):' "$tmp/zip.exr.dump" | awk '{ printf "%.6g %.6g %.6g", $4, $5, $6 }')
check "pixel (17, 11): pds '$ours', oiiotool '$theirs'" "[ '$ours' = '$theirs' ]"

# oiiotool's own EXR (half floats, ZIP) read by pds
oiio "$tmp/zip.exr" -d half --compression zip -o "$tmp/half.exr"
rmse=$(./pds compare "$tmp/half.exr" "$tmp/zip.exr" 2>"$tmp/compare.err" | sed -n 's/.*rmse=\([^ ]*\).*/\1/p')
check "pds reads oiiotool's half ZIP file (rmse $rmse against the float file)" \
    "awk -v r='$rmse' 'BEGIN { exit !(r != \"\" && r + 0 < 1e-3) }'"
check "no kind warning between the two" "! grep -q warning '$tmp/compare.err'"

if [ $fail -ne 0 ]; then exit 1; fi
echo "check_exr_oiio: OK ($(oiiotool --version 2>/dev/null | head -1): metadata, 768 pixels of ZIP and raw EXR equal the PFM's, half ZIP read back, rmse $rmse)"
