#!/bin/sh
# tests/core_lines.sh [-DSWITCH ...]: how many lines of pds.c a reader of
# the build with those switches has to read (default: -DPDS_CORE, the
# small core; README "A small core"), against all of pds.c.
#
# Counted: the non-blank lines, comments included, that the C
# preprocessor keeps with the switches, decided by the preprocessor
# itself. Every line of pds.c becomes a marker "@@ N"; the conditionals
# that name a switch (PDS_NO_*, PDS_CORE, PDS_TEST) and the switches'
# #defines stay as they are, and every other conditional (_WIN32, the
# system layer's features) is opened so that both its branches count, as
# a reader reads both. Then `$CC -E` with the switches keeps the markers
# of the lines that are in the build. The lines of the switch
# conditionals themselves are not counted.
#
# Prints: core: K of N non-blank lines of pds.c (SWITCHES)
set -eu
cd "$(dirname "$0")/.."
CC=${CC:-cc}
[ $# -gt 0 ] || set -- -DPDS_CORE
switch='PDS_(NO_[A-Z_]+|CORE|TEST)'
marked=$(awk -v sw="$switch" '
    function mark() { if ($0 ~ /[^ \t]/) print "@@ " NR; else print "" }
    /^#[ \t]*(if|ifdef|ifndef)[ \t(!]/ {
        if ($0 ~ sw) { stack[++d] = "switch"; print; print "" }
        else { stack[++d] = "both"; print "#if 1"; print "@@ " NR }
        next
    }
    /^#[ \t]*(elif|else)/ {
        if (stack[d] == "switch") { print; print "" }
        else { print "#endif"; print "#if 1"; print "@@ " NR }
        next
    }
    /^#[ \t]*endif/ {
        if (stack[d] == "switch") { print; print "" } else { print "#endif"; print "@@ " NR }
        d--
        next
    }
    /^#[ \t]*(define|undef)[ \t]/ && $0 ~ sw { print; print ""; next }
    { mark() }
' pds.c)
kept=$(printf '%s\n' "$marked" | $CC -E -P "$@" - | grep -c '^@@ ')
all=$(grep -c '[^ 	]' pds.c)
echo "core: $kept of $all non-blank lines of pds.c ($*)"
