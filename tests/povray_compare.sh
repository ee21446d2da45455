#!/bin/sh
# povray_compare.sh - PDS, pm and POV-Ray 3.7 at equal CPU time on
# scenes/ball.scene (README "PDS against POV-Ray"). Run from the top folder
# (make povray-compare). Minutes: the reference about 2 CPU-minutes, then
# every budget once per method and POV-Ray setting.
#
#   BUDGETS="9 18 27"    CPU seconds (user + sys) per image
#   REF_SIDE=16384       the reference's photons: REF_SIDE^2
#   OUT=tests/out/povray the images, logs and the table (table.txt)
#
# CPU time: /usr/bin/time's user + sys of the whole process (pds: scene
# load, BVH, eye pass, photons; POV-Ray: parse, photons, trace). Each
# method's knob is fitted to the budget from two calibration runs (CPU
# time is linear in the photon count), then the image is rendered once and
# its own CPU time reported. POV-Ray is tried with 3 x 3 and 4 x 4
# antialiasing samples a pixel (POV_AA="2 3 4" adds 2 x 2, which measured
# worse), each with the photon count that fills the budget.
#
# Metrics (tests/ball_metrics): rel4, the root mean square of the
# difference of 4 x 4 pixel block means divided by the reference's mean,
# and the plain RMSE, over the whole image, the ball's pixels and the
# caustic's (the reference's caustic part above 0.02). "full" compares the
# whole image; "caustic part" compares the caustic light alone: pds --caustics-only,
# and POV-Ray's image minus the reference's direct part (POV-Ray's direct
# light matches it to 0.01% in the median pixel; only its antialiasing at
# the shadow's edge stays in).
set -eu
OUT=${OUT:-tests/out/povray}
BUDGETS=${BUDGETS:-"9 18 27"}
REF_SIDE=${REF_SIDE:-16384}
SCENE=scenes/ball.scene
POV=tests/povray/ball.pov
mkdir -p "$OUT/rows"
make -s pds tests/ref_ball tests/ball_metrics

# cpu NAME CMD...: runs CMD (output in OUT/NAME.log), prints its CPU seconds
cpu() {
    name=$1
    shift
    /usr/bin/time -f "%U %S" -o "$OUT/$name.time" "$@" > "$OUT/$name.log" 2>&1
    awk '{ printf "%.2f\n", $1 + $2 }' "$OUT/$name.time"
}

# fit N1 C1 N2 C2 B: the knob value whose CPU time is B on the line through
# (N1, C1) and (N2, C2); at least N1 / 10
fit() {
    awk -v n1="$1" -v c1="$2" -v n2="$3" -v c2="$4" -v b="$5" 'BEGIN {
        n = n1 + (b - c1) * (n2 - n1) / (c2 - c1); if (n < n1 / 10) n = n1 / 10; printf "%d\n", n }'
}

# 1. The reference, and a second one (another seed, a quarter of the
#    photons, half the grid cell, 64 samples a pixel): the difference of the
#    two bounds the first one's own error (its grid's bias and its noise).
if [ ! -f "$OUT/ref.pfm" ]; then
    t=$(cpu ref tests/ref_ball --photons-side "$REF_SIDE" --spp-side 16 -o "$OUT/ref.pfm" \
        --caustics "$OUT/ref_c.pfm" --direct "$OUT/ref_d.pfm" --ball-mask "$OUT/mask.pfm")
    echo "reference: $REF_SIDE^2 photons, 256 samples a pixel, $t CPU-s"
    half=$((REF_SIDE / 2))
    tests/ref_ball --photons-side "$half" --spp-side 8 --cell 0.002 --seed 1 -o "$OUT/ref2.pfm" \
        --caustics "$OUT/ref2_c.pfm" > "$OUT/ref2.log"
fi
metrics() { # metrics IMAGE REF [more ball_metrics options]: "all ball caustic" rel4/rmse pairs
    img=$1
    ref=$2
    shift 2
    tests/ball_metrics "$img" "$ref" --ball "$OUT/mask.pfm" --caustic "$OUT/ref_c.pfm" "$@" |
        awk '{ for (i = 1; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
               if (v["region"] != "floor") printf " %s %s", v["rel4"], v["rmse"] } END { printf "\n" }'
}
{
    echo "# rows: method budget cpu_s setting | full image: rel4 rmse for all, ball, caustic | caustic part: the same"
    echo "reference2 - - seed1,cell0.002 |$(metrics "$OUT/ref2.pfm" "$OUT/ref.pfm") |$(metrics "$OUT/ref2_c.pfm" "$OUT/ref_c.pfm")"
} > "$OUT/table.txt"

# 2. pds (default; with eye paths of at most 2 bounces, which leaves out
#    the diffuse light the eye pass path-traces through the ball, L D S+ D E,
#    that neither POV-Ray nor the reference has; and with that, 16 samples
#    a pixel and footprints at least 3 eye-sample spacings wide, i.e. as
#    wide in pixels as the default's 1.5 at 4 samples) and pm (default
#    k 50): photons fitted to each budget.
#    A row already in OUT/rows is kept (delete it to measure it again).
photon_method() { # photon_method LABEL OPTIONS...
    label=$1
    shift
    c1=
    for b in $BUDGETS; do
        [ -f "$OUT/rows/$label.$b" ] && continue
        if [ -z "$c1" ]; then
            c1=$(cpu "$label.cal1" ./pds render $SCENE --photons 100000 --quiet -o "$OUT/$label.cal1.pfm" "$@")
            c2=$(cpu "$label.cal2" ./pds render $SCENE --photons 800000 --quiet -o "$OUT/$label.cal2.pfm" "$@")
        fi
        n=$(fit 100000 "$c1" 800000 "$c2" "$b")
        t=$(cpu "$label.$b" ./pds render $SCENE --photons "$n" --quiet -o "$OUT/$label.$b.pfm" "$@")
        ./pds render $SCENE --photons "$n" --caustics-only --quiet -o "$OUT/$label.$b.c.pfm" "$@" > /dev/null
        echo "$label $b $t photons=$n |$(metrics "$OUT/$label.$b.pfm" "$OUT/ref.pfm") |$(metrics "$OUT/$label.$b.c.pfm" "$OUT/ref_c.pfm")" > "$OUT/rows/$label.$b"
    done
}
photon_method pds
photon_method pds-depth2 --max-depth 2
photon_method pds-tuned --max-depth 2 --spp 16 --pass-min-width 3
photon_method pm --method pm
#    The same light transport as POV-Ray's and the reference's: direct light
#    and caustics at the first non-specular vertex, no indirect light.
#    (since 7 December 2026 a photon budget takes an eye round every 4
#    photons an eye sample by default, so these rows have rounds at the
#    larger budgets; pds-direct1 keeps the old default's one eye pass)
photon_method pds-direct --diffuse-bounces 0
photon_method pds-direct1 --diffuse-bounces 0 --eye-rounds 1
photon_method pm-direct --method pm --diffuse-bounces 0
#    ... and PDS's passes splatting into 4 or 16 eye passes (16 or 64
#    samples a pixel)
photon_method pds-rounds4 --diffuse-bounces 0 --eye-rounds 4
photon_method pds-rounds --diffuse-bounces 0 --eye-rounds 16

#    ... and PDS under a time budget, its defaults otherwise (eye rounds
#    as the time goes): --time fitted to the CPU budget from two runs, as
#    the photon counts are; the image's own photon count is in its log
for b in $BUDGETS; do
    label=pds-time
    [ -f "$OUT/rows/$label.$b" ] && continue
    if [ -z "${tc1:-}" ]; then
        tc1=$(cpu "$label.cal1" ./pds render $SCENE --time 1 --diffuse-bounces 0 -o "$OUT/$label.cal1.pfm")
        tc2=$(cpu "$label.cal2" ./pds render $SCENE --time 4 --diffuse-bounces 0 -o "$OUT/$label.cal2.pfm")
    fi
    tt=$(awk -v c1="$tc1" -v c2="$tc2" -v b="$b" 'BEGIN { t = 1 + (b - c1) * 3 / (c2 - c1); if (t < 0.1) t = 0.1; printf "%.2f\n", t }')
    t=$(cpu "$label.$b" ./pds render $SCENE --time "$tt" --diffuse-bounces 0 -o "$OUT/$label.$b.pfm")
    n=$(sed -n 's/.* photons=\([0-9]*\) .*/\1/p' "$OUT/$label.$b.log" | tail -n 1)
    echo "$label $b $t time=$tt,photons=$n |$(metrics "$OUT/$label.$b.pfm" "$OUT/ref.pfm") | - - - - - -" > "$OUT/rows/$label.$b"
done

# 3. POV-Ray, if installed: 3 x 3 and 4 x 4 regular samples a pixel
#    (antialiasing method 1, threshold 0, no jitter, linear averaging),
#    photons (count) fitted to each budget.
if command -v povray > /dev/null 2>&1; then
    for r in ${POV_AA:-3 4}; do
        pov() { # pov NAME COUNT
            cpu "$1" povray +I$POV +W320 +H240 +FE +O"$OUT/$1.exr" +A0.0 +AM1 +R$r -J Antialias_Gamma=1.0 \
                +WT2 -D -GA declare=Count="$2"
        }
        c1=
        for b in $BUDGETS; do
            [ -f "$OUT/rows/pov-r$r.$b" ] && continue
            if [ -z "$c1" ]; then
                c1=$(pov "pov-r$r.cal1" 300000)
                c2=$(pov "pov-r$r.cal2" 3000000)
            fi
            # POV-Ray's time is not linear in the count: one secant step
            # from the first try when it misses the budget by over 15%
            n=$(fit 300000 "$c1" 3000000 "$c2" "$b")
            t=$(pov "pov-r$r.$b" "$n")
            if awk -v t="$t" -v b="$b" 'BEGIN { exit !(t > 1.15 * b || t < 0.85 * b) }'; then
                if awk -v t="$t" -v b="$b" 'BEGIN { exit !(t > b) }'; then
                    n=$(fit 300000 "$c1" "$n" "$t" "$b")
                else
                    n=$(fit "$n" "$t" 3000000 "$c2" "$b")
                fi
                t=$(pov "pov-r$r.$b" "$n")
            fi
            echo "pov-r$r $b $t count=$n |$(metrics "$OUT/pov-r$r.$b.exr" "$OUT/ref.pfm") |$(metrics "$OUT/pov-r$r.$b.exr" "$OUT/ref_c.pfm" --subtract "$OUT/ref_d.pfm")" > "$OUT/rows/pov-r$r.$b"
        done
    done
else
    echo "povray not installed (Debian: apt-get install povray): its rows are left out"
fi
cat "$OUT"/rows/* >> "$OUT/table.txt"
cat "$OUT/table.txt"
