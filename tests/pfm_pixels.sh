#!/bin/sh
# tests/pfm_pixels.sh FILE.pfm: print the header and pixels of a PFM that
# pds wrote, without the metadata trailer after them (which holds render
# times and so differs between two runs of the same render). Used to
# compare images bit for bit with cmp.
set -eu
n=$(head -n 3 "$1" | wc -c)
# shellcheck disable=SC2046
set -- "$1" $(sed -n 2p "$1")
head -c $((n + $2 * $3 * 12)) "$1"
