#!/bin/sh
# examples/stream_fit.c end to end: a phantom sequence written by the CLI,
# streamed frame by frame into the one static buffer, against 'sqffd track'
# on the same frames; bad frames in the middle reported and skipped.
# Usage: sh tests/stream_test.sh [SQFFD] [STREAM_FIT]   (from the repository root)
SQFFD=${1:-build/sqffd}
STREAM=${2:-build/stream_fit}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/sqffd_stream.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT INT TERM
passed=0
failed=0
ok() { passed=$((passed + 1)); }
bad() { failed=$((failed + 1)); echo "FAIL stream: $*"; }

for x in "$SQFFD" "$STREAM"; do
    if [ ! -x "$x" ]; then echo "stream_test: no executable $x (run make first)"; exit 1; fi
done

# The reference: 6 frames of 3,000 points (noise 1% of the diagonal), tracked
# by the library's sqffd_track (the same steps and iteration caps).
"$SQFFD" phantom -o "$TMP/ph" --frames 6 --points 3000 --quiet || { bad "sqffd phantom failed"; exit 1; }
"$SQFFD" track "$TMP"/ph/points_*.ply -o "$TMP/track" --quiet || { bad "sqffd track failed"; exit 1; }
# per frame: the track error in percent and the iterations (volumes.csv: frame,file,volume,error_relative,iterations)
awk -F, 'NR > 1 { printf "%s %.10f %s\n", $1, 100 * $4, $5 }' "$TMP/track/volumes.csv" >"$TMP/track_errors"
[ "$(wc -l <"$TMP/track_errors")" -eq 6 ] && ok || bad "track wrote $(wc -l <"$TMP/track_errors") frames, not 6"

# check_frames OUT EXPECT: OUT is stream_fit's output, EXPECT one line per
# frame given: "fit PHANTOM_FRAME POINTS SUBSAMPLED_FROM|- MAX_ITERATIONS" or
# "fail KEPT_FRAME|none TEXT...". Every frame line is checked: its index, and
# for a fit its points, iterations (1 .. the cap: 100 first and later, as
# sqffd_track) and error. A frame streamed whole after the frames before it
# (no subsample, no bad frame between) is sqffd_track's to the bit
# (sqffd_track_frame), so its error must print as track's and its
# iterations equal track's; a subsampled one (2,500 of 3,000 points), or one
# after a skipped frame, must be above 0 and at most 1.1 x the track error
# of that phantom frame (measured: 0.96 to 1.01 x; frames left untracked,
# 0 FFD iterations from the previous model, are 1.6 to 5.1 x: the ventricle
# loses a third of its volume). Prints what fails.
check_frames() {
    awk -v want="$2" -v trackfile="$TMP/track_errors" '
        BEGIN {
            while ((getline line < trackfile) > 0) { split(line, f, " "); track[f[1]] = f[2]; iters[f[1]] = f[3] }
            while ((getline line < want) > 0) expect[nexp++] = line
            bad = 0
            seen = 0
        }
        function fail(msg) { print "frame " frame ": " msg; bad = 1 }
        $1 ~ /^[0-9]+$/ {
            frame = $1
            if (frame != seen) fail("index " frame " where " seen " was due")
            split(expect[seen], e, " ")
            if (e[1] == "fit") {
                if ($2 != e[3]) fail("points " $2 ", expected " e[3])
                else if ($4 < 1 || $4 > e[5]) fail("iterations " $4 " outside 1.." e[5])
                else if (e[4] == "-" && ($5 != sprintf("%.4f", track[e[2]]) || $4 != iters[e[2]]))
                    fail("error " $5 "% in " $4 " iterations, sqffd track: " sprintf("%.4f", track[e[2]]) "% in " iters[e[2]])
                else if (!($5 > 0 && $5 <= 1.1 * track[e[2]]))
                    fail("error " $5 "% against the bound 1.1 x " track[e[2]] "% (sqffd track, phantom frame " e[2] ")")
                else if (e[4] == "-" && $0 ~ /subsampled/) fail("says subsampled: " $0)
                else if (e[4] != "-" && $0 !~ ("subsampled from " e[4] "$")) fail("lacks subsampled from " e[4] ": " $0)
            } else if (e[1] == "fail") {
                kept = e[2] == "none" ? "no model yet" : "the model of frame " e[2] " kept"
                text = expect[seen]
                sub(/^fail [^ ]+ /, "", text)
                if ($2 != "failed:") fail("fitted, a failure was due: " $0)
                else if (index($0, text) == 0) fail("lacks \"" text "\": " $0)
                else if (index($0, "frame skipped, " kept) == 0) fail("lacks \"" kept "\": " $0)
            } else fail("unexpected frame line: " $0)
            seen++
            next
        }
        END {
            if (seen != nexp) { print seen " frame lines, " nexp " frames given"; bad = 1 }
            exit bad
        }' "$1"
}

# 1. The clean sequence: every frame fitted, exit 0.
"$STREAM" "$TMP"/ph/points_*.ply >"$TMP/out1" 2>"$TMP/err1"
status=$?
[ $status -eq 0 ] && ok || bad "clean sequence: exit $status, expected 0: $(head -c 300 "$TMP/err1")"
{
    echo "fit 0 3000 - 100"
    for t in 1 2 3 4 5; do echo "fit $t 3000 - 100"; done
} >"$TMP/want1"
check_frames "$TMP/out1" "$TMP/want1" >"$TMP/check1" && ok || bad "clean sequence: $(cat "$TMP/check1")"
grep -q "^summary: 6 frames, 6 fitted, 0 failed; first fit (frame 0) [0-9.]* ms; tracked frames median [0-9.]* ms (5); buffer [0-9]* bytes" \
    "$TMP/out1" && ok || bad "clean sequence: summary: $(grep summary "$TMP/out1")"

# The check can fail: the same output with one error doubled, or a line missing.
awk '$1 == "3" { $5 = 2 * $5 } { print }' "$TMP/out1" >"$TMP/doctored"
check_frames "$TMP/doctored" "$TMP/want1" >/dev/null && bad "the check passed a doubled error" || ok
grep -v '^    4 ' "$TMP/out1" >"$TMP/doctored"
check_frames "$TMP/doctored" "$TMP/want1" >/dev/null && bad "the check passed a missing frame line" || ok

# 2. Bad frames between the phantom's (a truncated PLY, a NaN, coordinates
# beyond the library's range, 3 points), and a capacity of 2,500 points: each
# bad frame reported and skipped, the next tracked from the model before it,
# every good frame subsampled; exit 1.
head -c 700 "$TMP/ph/points_02.ply" >"$TMP/truncated.ply"
printf '1 2 3\n4 5 nan\n7 8 9\n' >"$TMP/nan.xyz"
awk 'BEGIN { for (i = 0; i < 50; i++) printf "%d 1e200 %d\n", i, i * i }' >"$TMP/huge.xyz"
printf '0 0 0\n1 0 0\n0 1 0\n' >"$TMP/few.xyz"
P=$TMP/ph/points
"$STREAM" --max-points 2500 "${P}_00.ply" "${P}_01.ply" "$TMP/truncated.ply" "${P}_02.ply" "$TMP/nan.xyz" \
    "${P}_03.ply" "$TMP/huge.xyz" "${P}_04.ply" "$TMP/few.xyz" "${P}_05.ply" >"$TMP/out2" 2>"$TMP/err2"
status=$?
[ $status -eq 1 ] && ok || bad "bad frames: exit $status, expected 1: $(head -c 300 "$TMP/err2")"
cat >"$TMP/want2" <<EOF
fit 0 2500 3000 100
fit 1 2500 3000 100
fail 1 truncated.ply: header says 3000 vertices
fit 2 2500 3000 100
fail 3 nan.xyz: line 2: 'nan' is not a finite number
fit 3 2500 3000 100
fail 5 huge.xyz: input contains NaN, infinity or a value too large
fit 4 2500 3000 100
fail 7 few.xyz: too few points
fit 5 2500 3000 100
EOF
check_frames "$TMP/out2" "$TMP/want2" >"$TMP/check2" && ok || bad "bad frames: $(cat "$TMP/check2")"
grep -q "^summary: 10 frames, 6 fitted, 4 failed;" "$TMP/out2" && ok || bad "bad frames: summary: $(grep summary "$TMP/out2")"

# 3. A bad first frame: no model yet; the next frame gets the whole fit.
"$STREAM" "$TMP/few.xyz" "${P}_00.ply" "${P}_01.ply" >"$TMP/out3" 2>"$TMP/err3"
status=$?
[ $status -eq 1 ] && ok || bad "bad first frame: exit $status, expected 1"
printf 'fail none few.xyz: too few points\nfit 0 3000 - 100\nfit 1 3000 - 100\n' >"$TMP/want3"
check_frames "$TMP/out3" "$TMP/want3" >"$TMP/check3" && ok || bad "bad first frame: $(cat "$TMP/check3")"
grep -q "first fit (frame 1)" "$TMP/out3" && ok || bad "bad first frame: summary: $(grep summary "$TMP/out3")"

# 4. Usage: exit 2; a capacity the static buffer cannot hold is refused at start-up.
for args in "" "--max-points" "--max-points 5 x.ply" "--max-points 12x x.ply" "--bogus x.ply" \
    "--max-points 100000000 x.ply"; do
    # shellcheck disable=SC2086
    "$STREAM" $args >"$TMP/out4" 2>"$TMP/err4"
    status=$?
    [ $status -eq 2 ] && ok || bad "stream_fit $args: exit $status, expected 2"
done
grep -q "rebuild with -DSTREAM_ARENA_BYTES=" "$TMP/err4" && ok || bad "too large a capacity: $(cat "$TMP/err4")"
"$STREAM" --help >"$TMP/out4" 2>&1 && grep -q "^usage: stream_fit" "$TMP/out4" && ok || bad "stream_fit --help"

if [ $failed -ne 0 ]; then
    echo "stream test: $passed passed, $failed failed"
    exit 1
fi
echo "stream test: fixed-memory streaming of a 6-frame phantom equals sqffd track (subsampled frames within 1.1 x its error), bad frames skipped: $passed checks ok"
