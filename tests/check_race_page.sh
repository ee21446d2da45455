#!/usr/bin/env bash
# tests/check_race_page.sh - open the page `pds race` writes in a headless
# browser and check that it works as published: its inline script runs
# (the comparer marks <body data-comparer="ready">), every image it shows
# loads from the folder (data-broken-images="0"), no script error is
# logged, and the page names no network address. Uses Debian's chromium.
#
#   tests/check_race_page.sh            skip (exit 0, saying so) without chromium
#   tests/check_race_page.sh --install  apt-get install chromium first if missing
#
# Builds ./pds if needed; writes only under a temporary folder.
set -euo pipefail
cd "$(dirname "$0")/.."

browser=""
find_browser() {
    for b in chromium chromium-browser google-chrome; do
        if command -v "$b" >/dev/null 2>&1; then browser=$b; return 0; fi
    done
    return 1
}
if ! find_browser && [ "${1:-}" = "--install" ]; then
    echo "check_race_page: installing chromium"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null || true
    find_browser || true
fi
if [ -z "$browser" ]; then
    echo "check_race_page: SKIP: no chromium (apt-get install chromium, or run with --install)"
    exit 0
fi

[ -x ./pds ] || make pds >/dev/null
tmp=$(mktemp -d /tmp/pds_check_race_page.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

# a neutral reference (ppm, caustics only), then a tuned race on two budgets
./pds render tests/golden/glass.scene --method ppm --caustics-only --photons 20000 --passes 8 \
    --res 32x24 --spp 4 --quiet -o "$tmp/ref.pfm" >/dev/null
./pds race tests/golden/glass.scene --ref "$tmp/ref.pfm" --methods pds,pm,ppm --caustics-only \
    --budgets 1000,4000 --budget-kind photons --tune --res 32x24 --spp 4 --quiet -o "$tmp/race" \
    >/dev/null 2>"$tmp/race.err"

fail=0
check() { if ! eval "$2"; then echo "check_race_page: FAIL: $1"; fail=1; fi; }

page="$tmp/race/index.html"
check "the page names no network address" "! grep -Eq 'https?://' '$page'"
check "one script, inline" "[ \$(grep -c '<script' '$page') = 1 ] && ! grep -q '<script[^>]*src=' '$page'"

timeout 60 "$browser" --headless --no-sandbox --disable-gpu --disable-dev-shm-usage --no-first-run \
    --enable-logging=stderr --v=0 --virtual-time-budget=3000 --dump-dom "file://$page" \
    >"$tmp/dom.html" 2>"$tmp/browser.log" || true
check "the browser produced a DOM" "grep -q '</body>' '$tmp/dom.html'"
check "the comparer's script ran" "grep -q 'data-comparer=\"ready\"' '$tmp/dom.html'"
check "every image loaded" "grep -q 'data-broken-images=\"0\"' '$tmp/dom.html'"
check "the comparer labels its view" "grep -q 'left: reference, right: pds' '$tmp/dom.html'"
check "no script error" "! grep -Eq 'Uncaught|SyntaxError|ReferenceError|TypeError' '$tmp/browser.log'"
if [ $fail -ne 0 ]; then
    echo "--- browser log"; tail -20 "$tmp/browser.log"
    exit 1
fi
echo "check_race_page: OK ($browser: script ran, $(grep -o '<img' "$page" | wc -l) images loaded, no network)"
