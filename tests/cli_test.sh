#!/bin/sh
# End-to-end checks of the sqffd command: exit statuses, messages, and the
# PLY it writes. Usage: sh tests/cli_test.sh [PATH_TO_SQFFD]   (from the repository root)
SQFFD=${1:-build/sqffd}
DATA=tests/data/bunny.ply
TMP=$(mktemp -d "${TMPDIR:-/tmp}/sqffd_cli.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT INT TERM
passed=0
failed=0

ok() { passed=$((passed + 1)); }
bad() { failed=$((failed + 1)); echo "FAIL cli: $*"; }
# true under make check (SQFFD_TESTS_THOROUGH set): the longer sweeps run there
thorough() { [ -n "${SQFFD_TESTS_THOROUGH:-}" ]; }

# expect STATUS 'TEXT IN STDERR OR STDOUT' ARGS...: runs sqffd ARGS, checks the exit status and the text
expect() {
    want=$1 text=$2
    shift 2
    "$SQFFD" "$@" >"$TMP/out" 2>"$TMP/err"
    got=$?
    if [ "$got" != "$want" ]; then
        bad "sqffd $*: exit $got, expected $want; stderr: $(head -c 300 "$TMP/err")"
    elif [ -n "$text" ] && ! grep -qF -- "$text" "$TMP/out" "$TMP/err"; then
        bad "sqffd $*: output lacks '$text': $(head -c 300 "$TMP/out" "$TMP/err")"
    else
        ok
    fi
}

# every option a command's help describes is in its usage line (the README's synopsis is that line;
# track's names fit's options as a group)
fit_usage=$("$SQFFD" fit --help 2>&1 | head -n 1)
for cmd in fit track phantom; do
    "$SQFFD" $cmd --help >"$TMP/help" 2>&1
    usage=$(head -n 1 "$TMP/help")
    for opt in $(tail -n +2 "$TMP/help" | grep -o -- '^ *--[a-z-]*' | tr -d ' ' | sort -u); do
        case "$usage" in
        *"$opt"*) ok ;;
        *"options of fit"*) case "$fit_usage" in *"$opt"*) ok ;; *) bad "$cmd's usage line lacks $opt" ;; esac ;;
        *) bad "$cmd's usage line lacks $opt" ;;
        esac
    done
done

# check_ply FILE: the header's counts agree with the file's size (binary) or line count (ascii)
check_ply() {
    LC_ALL=C awk '/^end_header/ { exit } { print }' "$1" >"$TMP/header"
    nv=$(awk '$1 == "element" && $2 == "vertex" { print $3 }' "$TMP/header")
    nf=$(awk '$1 == "element" && $2 == "face" { print $3 }' "$TMP/header")
    np=$(awk '$1 == "element" && $2 == "vertex" { v = 1; next } $1 == "element" { v = 0 } v && $1 == "property" { n++ } END { print n + 0 }' "$TMP/header")
    nf=${nf:-0}
    if [ -z "$nv" ] || [ "$nv" -le 0 ]; then bad "$1: no vertex count in the header"; return; fi
    if grep -q '^format ascii 1.0' "$TMP/header"; then
        lines=$(($(wc -l <"$1") - $(wc -l <"$TMP/header") - 1))
        [ "$lines" -eq $((nv + nf)) ] && ok || bad "$1: $lines data lines, header says $nv vertices + $nf faces"
    else
        hsize=$(($(wc -c <"$TMP/header") + 11)) # + "end_header\n"
        want=$((hsize + nv * 4 * np + nf * 13))
        size=$(wc -c <"$1")
        [ "$size" -eq "$want" ] && ok || bad "$1: $size bytes, header says $nv vertices of $np floats + $nf triangles = $want"
    fi
}

# ply_rows FILE: an ascii PLY's float vertex property names on one line, then its vertex rows
ply_rows() {
    LC_ALL=C awk '/^property float / { printf "%s%s", np++ ? " " : "", $3 } /^element vertex / { nv = $3 }
        /^end_header/ { print ""; body = 1; next } body && row < nv { row++; print }' "$1"
}

if [ ! -x "$SQFFD" ]; then echo "cli_test: no executable $SQFFD (run make first)"; exit 1; fi

# usage and help
expect 2 "usage: sqffd COMMAND"
expect 0 "usage: sqffd COMMAND" --help
expect 0 "sqffd 0." --version
expect 0 "usage: sqffd fit" help fit
expect 0 "--lattice N|LxMxN" fit --help
expect 2 "unknown command 'fitt'" fitt
expect 2 "no output file" fit "$DATA"
expect 2 "no INPUT" fit -o "$TMP/x.ply"
expect 2 "a second" fit "$DATA" "$DATA" -o "$TMP/x.ply"
expect 2 "needs a value" fit "$DATA" -o
expect 2 "unknown option '--lattic'" fit "$DATA" -o "$TMP/x.ply" --lattic 5
expect 2 "takes no value" fit "$DATA" -o "$TMP/x.ply" --robust=1
expect 2 "unknown option" fit "$DATA" -o "$TMP/x.ply" --alpa=1
for v in 1 9 0x5 5x5 5x5x5x5 5x1x5 -5 " 5" 5.0 abc ""; do
    expect 2 "--lattice must be" fit "$DATA" -o "$TMP/x.ply" --lattice "$v"
done
for v in -1 nan inf 1e400 "" 0.1x; do
    expect 2 "--alpha must be" fit "$DATA" -o "$TMP/x.ply" --alpha "$v"
done
for v in -1 nan inf ""; do
    expect 2 "--model-to-data must be" fit "$DATA" -o "$TMP/x.ply" --model-to-data "$v"
done
for v in 10001 2.5 30x -3 ""; do
    expect 2 "--iterations must be" fit "$DATA" -o "$TMP/x.ply" --iterations "$v"
done
for v in 10001 -1 ""; do
    expect 2 "--coarse-iterations must be" fit "$DATA" -o "$TMP/x.ply" --coarse-iterations "$v"
done
expect 2 "--mesh must be" fit "$DATA" -o "$TMP/x.ply" --mesh 3

# bad input: exit 1 and "FILE: what is wrong"
expect 1 "$TMP/missing.ply: cannot open" fit "$TMP/missing.ply" -o "$TMP/x.ply"
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n1 2\n3 4\n' >"$TMP/noz.ply"
expect 1 "$TMP/noz.ply: vertex element has no 'z' property" fit "$TMP/noz.ply" -o "$TMP/x.ply"
printf '1 2 3\n4 5\n' >"$TMP/short.xyz"
expect 1 "$TMP/short.xyz: line 2: expected 3 numbers" fit "$TMP/short.xyz" -o "$TMP/x.ply"
: >"$TMP/empty.xyz"
expect 1 "$TMP/empty.xyz: file is empty" fit "$TMP/empty.xyz" -o "$TMP/x.ply"
printf '1 2 3\n4 5 6\n' >"$TMP/two.xyz"
expect 1 "$TMP/two.xyz: 2 points; at least 13 are needed" fit "$TMP/two.xyz" -o "$TMP/x.ply"
# files of formats sqffd does not read: one line that names the format (fit and info alike)
zeros() { head -c "$1" /dev/zero; }
foreign() { # FILE 'TEXT': both commands exit 1 with "FILE: TEXT" as their only line
    expect 1 "$1: $2" fit "$1" -o "$TMP/x.ply"
    [ "$(wc -l <"$TMP/err")" -eq 1 ] && ok || bad "sqffd fit $1: more than one line: $(head -c 300 "$TMP/err")"
    expect 1 "$1: $2" info "$1"
}
{ zeros 128; printf 'DICM\002\000\000\000UL\004\000'; zeros 40; } >"$TMP/scan.dcm"
foreign "$TMP/scan.dcm" "DICOM is not read by sqffd; convert it to NIfTI (e.g. with dcm2niix)"
if command -v gzip >/dev/null 2>&1; then
    gzip -c "$TMP/scan.dcm" >"$TMP/scan.dcm.gz"
    foreign "$TMP/scan.dcm.gz" "DICOM is not read by sqffd"
fi
{ printf '#INRIMAGE-4#{\nXDIM=64\nYDIM=64\nZDIM=64\nVDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n##}\n'; zeros 64; } >"$TMP/skull.inr"
foreign "$TMP/skull.inr" "INRIMAGE is not read by sqffd"
{ printf '\134\001\000\000'; zeros 344; } >"$TMP/analyze.hdr"
zeros 48 >"$TMP/analyze.img"
foreign "$TMP/analyze.hdr" "Analyze 7.5 (a .hdr without the NIfTI-1 magic) is not read by sqffd; convert it to NIfTI"
expect 1 "$TMP/analyze.hdr: Analyze 7.5" fit "$TMP/analyze.img" -o "$TMP/x.ply"
{ printf '\000\000\001\134'; zeros 344; } >"$TMP/analyze_be.dat"
foreign "$TMP/analyze_be.dat" "Analyze 7.5"
{ printf '\211HDF\r\n\032\n'; zeros 92; } >"$TMP/volume.mnc"
foreign "$TMP/volume.mnc" "HDF5 (e.g. MINC 2) is not read by sqffd"
{ printf 'PK\003\004'; zeros 60; } >"$TMP/points.zip"
foreign "$TMP/points.zip" "a zip archive is not read by sqffd; unpack it first"
printf '1 2 3\n4 5 6\n\001\002\003\n' >"$TMP/binary.xyz"
foreign "$TMP/binary.xyz" "not a text point file (binary byte 0x01 at line 3)"
[ ! -e "$TMP/x.ply" ] && ok || bad "a refused input left an output file"
expect 0 "(the superquadric alone)" fit "$DATA" -o "$TMP/sq.ply" --iterations 0 --mesh 8
expect 0 "after FFD" fit "$DATA" -o "$TMP/m2d.ply" --model-to-data 0 --iterations 2 --mesh 8
# the Jacobian floor: its bound in the report, 'none' lifts it, anything but a number <= 1 is a usage error
expect 0 "(its certified lower bound on the model's region: > 0, no fold)" fit "$DATA" -o "$TMP/j.ply" --iterations 3 --mesh 8
expect 0 "after FFD" fit "$DATA" -o "$TMP/j.ply" --min-jacobian none --iterations 3 --mesh 8
for v in 1.5 nan abc ""; do
    expect 2 "--min-jacobian must be" fit "$DATA" -o "$TMP/x.ply" --min-jacobian "$v"
done
expect 0 "iterations       3 coarse + 2 (iteration cap: not converged)" fit "$DATA" -o "$TMP/c.ply" --iterations 5 --coarse-iterations 3 --mesh 8
expect 0 "iterations       5 (iteration cap: not converged)" fit "$DATA" -o "$TMP/c.ply" --iterations 5 --coarse-iterations 0 --mesh 8
expect 1 "$TMP/no/dir/out.ply: cannot create" fit "$DATA" -o "$TMP/no/dir/out.ply" --iterations 2 --mesh 8
[ ! -e "$TMP/x.ply" ] && ok || bad "a failed run left an output file"

# a real fit: the report, and PLY files consistent with their headers
expect 0 "points read      1839" fit "$DATA" -o "$TMP/bunny.ply" --points "$TMP/points.ply"
for word in "superquadric" "after FFD" "iterations" "time"; do
    grep -q "$word" "$TMP/out" && ok || bad "report lacks '$word'"
done
check_ply "$TMP/bunny.ply"
check_ply "$TMP/points.ply"
grep -q '^element vertex 1839$' "$TMP/points.ply" && ok || bad "points.ply does not hold the 1839 points"
expect 0 "" fit "$DATA" -o "$TMP/bunny_ascii.ply" --ascii --quiet --lattice 4x5x6 --alpha=0.01 --iterations 5 --mesh 16x32
[ ! -s "$TMP/out" ] && ok || bad "--quiet printed: $(head -c 200 "$TMP/out")"
check_ply "$TMP/bunny_ascii.ply"
grep -q '^property float error$' "$TMP/bunny_ascii.ply" && ok || bad "no per-vertex error property"
# the written mesh reads back through sqffd's own reader as a point file
expect 0 "points read      " fit "$TMP/bunny.ply" -o "$TMP/again.ply" --iterations 2 --mesh 8

# phantom -> track -> motion.ply read back
expect 0 "usage: sqffd track" track --help
expect 0 "usage: sqffd phantom" phantom --help
expect 2 "at least two are needed" track "$DATA" -o "$TMP/t"
expect 2 "no output folder" track "$DATA" "$DATA"
expect 2 "--septum takes" track "$DATA" "$DATA" -o "$TMP/t" --septum 1,2
expect 2 "--ed 5: there are 2 frames" track "$DATA" "$DATA" -o "$TMP/t" --ed 5
expect 2 "--low-motion must be" track "$DATA" "$DATA" -o "$TMP/t" --low-motion 2
expect 2 "--frames must be" phantom -o "$TMP/ph" --frames 1
expect 2 "--low-motion takes" phantom -o "$TMP/ph" --low-motion 0.5,1,2
expect 2 "no output folder" phantom --frames 4
expect 1 "$TMP/missing.ply: cannot open" track "$DATA" "$TMP/missing.ply" -o "$TMP/t"
expect 1 "$TMP/two.xyz (frame 1): 2 points: a frame needs at least 13" track "$DATA" "$TMP/two.xyz" -o "$TMP/t"
expect 1 "cannot make the output folder" track "$DATA" "$DATA" -o "$DATA"
expect 0 "true ejection fraction" phantom -o "$TMP/ph" --frames 8 --points 3000 --noise 0.01
true_ef=$(awk '/true ejection fraction/ { print $4 }' "$TMP/out")
[ "$(ls "$TMP"/ph/points_*.ply | wc -l)" -eq 8 ] && ok || bad "phantom did not write 8 point files"
[ "$(wc -l <"$TMP/ph/truth.csv")" -eq 9 ] && ok || bad "truth.csv does not hold 8 frames"
expect 0 "ejection fraction" track "$TMP"/ph/points_*.ply -o "$TMP/tr" --septum -1,0,0 --ascii
ef=$(awk '/^  ejection fraction/ { print $3 }' "$TMP/out")
awk -v a="$ef" -v b="$true_ef" 'BEGIN { d = a - b; exit !(d <= 2 && d >= -2) }' && ok ||
    bad "track's EF $ef is not within 2 points of the phantom's $true_ef"
for word in "end-diastolic volume" "end-systolic volume" "apical lateral" "apex"; do
    grep -q "$word" "$TMP/out" && ok || bad "track report lacks '$word'"
done
for k in 00 07; do check_ply "$TMP/tr/frame_$k.ply"; done
check_ply "$TMP/tr/motion.ply"
[ "$(wc -l <"$TMP/tr/volumes.csv")" -eq 9 ] && ok || bad "volumes.csv does not hold 8 frames"
[ "$(wc -l <"$TMP/tr/segments.csv")" -eq 18 ] && ok || bad "segments.csv does not hold 17 segments"
# motion.ply: its properties, flags 0/1, segments 0..17 with each of 1..17 present, displacements >= 0
ply_rows "$TMP/tr/motion.ply" | LC_ALL=C awk '
    NR == 1 { np = NF; for (k = 0; k < np; k++) prop[k] = $(k + 1); next }
    {
        for (k = 0; k < np; k++) v[prop[k]] = $(k + 1)
        if (v["displacement"] < 0 || (v["low_motion"] != 0 && v["low_motion"] != 1) || v["segment"] < 0 || v["segment"] > 17) bad++
        seen[v["segment"]] = 1
        low += v["low_motion"]
    }
    END {
        if (np != 7 || prop[3] != "displacement" || prop[4] != "excursion" || prop[5] != "low_motion" || prop[6] != "segment") exit 1
        for (s = 1; s <= 17; s++) if (!seen[s]) exit 2
        exit (bad > 0 || low == 0) ? 3 : 0
    }' && ok || bad "motion.ply: wrong properties or values (awk status $?)"

# ED is the frame of largest volume: ES then ED gives the EF of ED then ES (it gave 0.0 %), the motion from ED
PH0=$TMP/ph/points_00.ply PH3=$TMP/ph/points_03.ply
expect 0 "ejection fraction" track "$PH0" "$PH3" -o "$TMP/fw" --septum -1,0,0 --json "$TMP/fw.json"
cp "$TMP/out" "$TMP/fw.out"
ef_fw=$(awk '/^  ejection fraction/ { print $3 }' "$TMP/fw.out")
expect 0 "end-diastolic volume" track "$PH3" "$PH0" -o "$TMP/rv" --septum -1,0,0
ef_rv=$(awk '/^  ejection fraction/ { print $3 }' "$TMP/out")
awk -v a="$ef_fw" -v b="$ef_rv" 'BEGIN { exit !(a > 30 && a - b <= 1 && b - a <= 1) }' && ok ||
    bad "track ES ED: EF $ef_rv, ED ES: $ef_fw (not within a point)"
grep -q "(frame 1, the largest volume)" "$TMP/out" && grep -Eq '^ +1 .* ED$' "$TMP/out" && ok ||
    bad "track ES ED: ED is not frame 1: $(grep -E 'diastolic|^ +[01] ' "$TMP/out")"
exc_fw=$(awk '/^  median wall excursion/ { print $7 }' "$TMP/fw.out")
exc_rv=$(awk '/^  median wall excursion/ { print $7 }' "$TMP/out")
awk -v a="$exc_fw" -v b="$exc_rv" 'BEGIN { exit !(a > 1 && b > 0.7 * a && b < 1.3 * a) }' && ok ||
    bad "track ES ED: median excursion $exc_rv, ED ES: $exc_fw (the motion not from ED to ES)"
expect 0 "--ed 1 is not the frame of largest volume: frame 0" track "$PH0" "$PH3" -o "$TMP/rv" --septum -1,0,0 --ed 1
grep -q "septum           not given" "$TMP/fw.out" && bad "track --septum: the report says it was not given" || ok
expect 0 "septum           not given (--septum X,Y,Z)" track "$PH0" "$PH3" -o "$TMP/rv" --frame-iterations 3
grep -Eq '^ +1 +3000 +0 .* 3 \(cap\) ' "$TMP/out" && ok || bad "track: an iteration count at the cap is not marked: $(grep -E '^ +1 ' "$TMP/out")"
# the hypokinetic flag agrees with the share printed beside it (cut to 0.1 %, never rounded up to 50 %)
awk '/^ +[0-9]+ (basal|mid|apical|apex)/ { s = $(NF - 2); f = $NF; if ((s >= 50) != (f == "yes")) bad++; n++ }
     END { exit bad || n != 17 }' "$TMP/fw.out" && ok || bad "track: a hypokinetic flag disagrees with its share"

# units: --mm-per-unit 2 gives 8 x the volumes and 2 x the lengths of the default, exactly; the default is assumed
grep -q "unit assumed to be mm" "$TMP/fw.out" && ok || bad "track: the default unit on point files is not said to be assumed"
expect 0 "2 mm per unit" track "$PH0" "$PH3" -o "$TMP/mm" --septum -1,0,0 --json "$TMP/mm.json" --mm-per-unit 2
grep -q "assumed" "$TMP/out" && bad "track --mm-per-unit 2: the unit is still said to be assumed" || ok
for key in edv_ml esv_ml median_excursion_mm ef_percent; do
    a=$(awk -v k="\"$key\":" '$1 == k { sub(",", "", $2); print $2 }' "$TMP/fw.json")
    b=$(awk -v k="\"$key\":" '$1 == k { sub(",", "", $2); print $2 }' "$TMP/mm.json")
    f=$(case $key in *_ml) echo 8;; *_mm) echo 2;; *) echo 1;; esac)
    awk -v a="$a" -v b="$b" -v f="$f" 'BEGIN { exit !(a != "" && a * f == b + 0) }' && ok ||
        bad "track --mm-per-unit 2: $key $b, not $f x $a"
done
expect 2 "--mm-per-unit takes a finite number > 0" track "$PH0" "$PH3" -o "$TMP/mm" --mm-per-unit 0
expect 2 "--mm-per-unit takes a finite number > 0" track "$PH0" "$PH3" -o "$TMP/mm" --mm-per-unit -1
expect 2 "--mm-per-unit takes a finite number > 0" track "$PH0" "$PH3" -o "$TMP/mm" --mm-per-unit nan
expect 2 "--mm-per-unit takes a finite number > 0" track "$PH0" "$PH3" -o "$TMP/mm" --mm-per-unit inf
expect 2 "is a volume (NIfTI" track tests/data/example4d.nii.gz -o "$TMP/mm" --mm-per-unit 2
# the JSON summary: strict JSON (NaN would be null), and what the report prints
if command -v python3 >/dev/null 2>&1; then
    python3 - "$TMP/fw.json" "$TMP/mm.json" "$ef_fw" <<'PY' && ok || bad "track --json: the summary disagrees (see above)"
import json, sys
def strict(name):
    return json.load(open(name, encoding="utf-8"), parse_constant=lambda c: sys.exit("%s: %s is no JSON" % (name, c)))
one, two = strict(sys.argv[1]), strict(sys.argv[2])
assert one["format"] == "sqffd-track" and one["units"]["mm_per_unit_source"] == "assumed", one["units"]
assert two["units"] == {"mm_per_unit": 2, "mm_per_unit_source": "given", "volume": "ml", "length": "mm", "area": "mm2"}
assert "%.1f" % one["ef_percent"] == sys.argv[3], (one["ef_percent"], sys.argv[3])
assert one["ed_index"] == 0 and one["es_index"] == 1 and one["septum_given"] and len(one["segments"]) == 17
for f1, f2 in zip(one["frames"], two["frames"]):
    assert f1["points"] == 3000 and f1["lid_points"] == 0 and f1["stop"] in ("converged", "capped", "no progress"), f1
    assert f2["volume_ml"] == 8 * f1["volume_ml"] and f2["error_mm"] == 2 * f1["error_mm"], (f1, f2)
    assert f2["error_relative"] == f1["error_relative"] and f2["iterations"] == f1["iterations"]
for s1, s2 in zip(one["segments"], two["segments"]):
    assert s2["area_mm2"] == 4 * s1["area_mm2"] and s2["excursion_mm"] == 2 * s1["excursion_mm"], (s1, s2)
    assert s2["share"] == s1["share"] and s1["hypokinetic"] == (s1["share"] >= one["hypokinetic_share"]), s1
PY
else
    echo "cli_test: no python3: the JSON summary checked by grep only"
    grep -q '"ef_percent": '"$ef_fw" "$TMP/fw.json" && ! grep -qi 'nan\|inf' "$TMP/fw.json" && ok ||
        bad "track --json: no EF $ef_fw, or a NaN"
fi

# every frame meets a lone fit's checks, refused up front (no output folder made), whatever the order
awk 'BEGIN { n = 500; for (i = 0; i < n; i++) { z = 1 - (2 * i + 1) / n; r = sqrt(1 - z * z); a = 2.399963229728653 * i
    printf "%.12g %.12g %.12g\n", 10 * r * cos(a), 10 * r * sin(a), 10 * z } }' >"$TMP/sphere.xyz"
awk 'NR <= 12' "$TMP/sphere.xyz" >"$TMP/twelve.xyz"
awk 'NR <= 4' "$TMP/sphere.xyz" >"$TMP/four.xyz"
awk '{ print $1, $2, 0 }' "$TMP/sphere.xyz" >"$TMP/flat.xyz"
awk '{ print 0, 0, $3 }' "$TMP/sphere.xyz" >"$TMP/line.xyz"
expect 1 "four.xyz (frame 1): 4 points: a frame needs at least 13" track "$DATA" "$TMP/four.xyz" -o "$TMP/no"
expect 1 "twelve.xyz (frame 1): 12 points: a frame needs at least 13" track "$DATA" "$TMP/twelve.xyz" -o "$TMP/no"
expect 1 "twelve.xyz (frame 0): 12 points: a frame needs at least 13" track "$TMP/twelve.xyz" "$DATA" -o "$TMP/no"
expect 1 "flat.xyz (frame 1): the points are all in one place, on a line or on a plane" track "$DATA" "$TMP/flat.xyz" -o "$TMP/no"
expect 1 "line.xyz (frame 2): the points are all in one place, on a line or on a plane" track "$DATA" "$DATA" "$TMP/line.xyz" -o "$TMP/no"
[ -e "$TMP/no" ] && bad "track: a refused frame left an output folder" || ok
# a frame the model cannot follow fails the track: a sphere, then the same sphere shrunk 20,000 times
awk '{ printf "%.12g %.12g %.12g\n", $1 * 5e-5, $2 * 5e-5, $3 * 5e-5 }' "$TMP/sphere.xyz" >"$TMP/tiny.xyz"
expect 1 "tiny.xyz (frame 1): the model did not follow this frame" track "$TMP/sphere.xyz" "$TMP/tiny.xyz" -o "$TMP/sph"
grep -q "ejection fraction" "$TMP/out" && bad "track: an EF printed from a frame the model did not follow" || ok
# the septum and the apex: refused up front, naming the option
expect 2 "--septum 0,0,0: a direction needs a non-zero length" track "$PH0" "$PH3" -o "$TMP/no" --septum 0,0,0
expect 2 "--apex 0,0,0: a direction needs a non-zero length" track "$PH0" "$PH3" -o "$TMP/no" --apex 0,0,0
expect 2 "--septum 1,0,0 is 0.0 degrees from --apex" track "$PH0" "$PH3" -o "$TMP/no" --apex 1,0,0 --septum 1,0,0
expect 2 "--septum 0.2,0,-1 is 11.3 degrees from --apex" track "$PH0" "$PH3" -o "$TMP/no" --apex 0,0,-1 --septum 0.2,0,-1
expect 2 "--septum takes a direction" track "$PH0" "$PH3" -o "$TMP/no" --septum nan,0,0
expect 2 "--apex takes a direction" track "$PH0" "$PH3" -o "$TMP/no" --apex 1e999,0,0
[ -e "$TMP/no" ] && bad "track: a refused option left an output folder" || ok
# ... and a septum along the long axis the model shows (the phantom's: z)
expect 2 "from the long axis found" track "$PH0" "$PH3" -o "$TMP/sa" --septum 0,0.1,1
axis=$(awk '$1 == "\"long_axis\":" { gsub(/[][ ]/, ""); sub(/^"long_axis":/, ""); sub(/,$/, ""); print }' "$TMP/fw.json")
expect 2 "is 0.0 degrees from the long axis found" track "$PH0" "$PH3" -o "$TMP/sa" --septum "$axis"
# the heart wall: the phantom's epicardium tracked with its cavity (--epi); the LV mass within 2 % of the truth
# 'sqffd phantom --epi' prints; the report, segments.csv, motion.ply, thickening.svg and --json agree
expect 0 "true LV mass  ED" phantom -o "$TMP/wph" --frames 8 --points 3000 --noise 0.01 --epi
true_mass=$(awk '/true LV mass/ { print $5, $8 }' "$TMP/out")
[ "$(ls "$TMP"/wph/epi_points_*.ply | wc -l)" -eq 8 ] && [ "$(head -n 1 "$TMP/wph/truth.csv")" = "frame,phase,volume,myocardium" ] &&
    ok || bad "phantom --epi did not write 8 epicardial point files and the myocardium's truth"
EPI=$(ls "$TMP"/wph/epi_points_*.ply | paste -sd, -)
expect 0 "LV mass          ED" track "$TMP"/wph/points_*.ply --epi "$EPI" -o "$TMP/wtr" --septum -1,0,0 --json "$TMP/wtr.json" --ascii
cp "$TMP/out" "$TMP/wtr.out"
mass=$(awk '/^  LV mass/ { print $4, $7 }' "$TMP/wtr.out")
echo "$mass $true_mass" | awk '{ exit !($1 > 0 && $3 > 0 && ($1 / $3 - 1) ^ 2 < 0.02 ^ 2 && ($2 / $4 - 1) ^ 2 < 0.02 ^ 2) }' && ok ||
    bad "track --epi: LV mass ED, ES $mass g, not within 2 % of the phantom's $true_mass"
grep -q "global thickening" "$TMP/wtr.out" && grep -q "dysfunctional (thickening < 20 %)" "$TMP/wtr.out" && ok ||
    bad "track --epi: the report lacks the thickening or the dysfunctional rule"
[ "$(ls "$TMP"/wtr/epi_frame_*.ply | wc -l)" -eq 8 ] && ok || bad "track --epi did not write 8 epicardial meshes"
check_ply "$TMP/wtr/epi_frame_04.ply"
check_ply "$TMP/wtr/motion.ply"
# motion.ply: thickness_ed > 0 where measured, NaN on the valve plane; thickening NaN where thickness_ed is (and
# where the ES thickness is not measured)
ply_rows "$TMP/wtr/motion.ply" | LC_ALL=C awk '
    NR == 1 { np = NF; for (k = 0; k < np; k++) prop[k] = $(k + 1); next }
    {
        for (k = 0; k < np; k++) v[prop[k]] = $(k + 1)
        t = v["thickness_ed"]; g = v["thickening"]
        if ((t ~ /nan/ && g !~ /nan/) || (v["segment"] == 0 && t !~ /nan/)) bad++
        if (t !~ /nan/) { if (t <= 0) bad++; n++ }
        if (g !~ /nan/) measured++
    }
    END { exit (np != 9 || prop[7] != "thickness_ed" || prop[8] != "thickening" || bad || measured < 1000 || n < measured) }' &&
    ok || bad "motion.ply: no thickness_ed and thickening, or wrong values"
head -n 1 "$TMP/wtr/segments.csv" | grep -q ',hypokinetic,thickness_ed_mm,thickness_es_mm,thickening_percent,dysfunctional$' && ok ||
    bad "segments.csv: no wall columns: $(head -n 1 "$TMP/wtr/segments.csv")"
# per segment: the CSV's thickening and flag as the report's, and the flag is the rule (thickening < 20 %)
awk -F, 'NR == FNR { if (FNR > 1) { t[$1] = sprintf("%.1f", $10); tn[$1] = $10 + 0; d[$1] = $11 }; next }
         /thickness ED mm/ { table = 1; next }
         table && seen < 17 { seen++; k = $1
             if (t[k] != $(NF - 1) || (d[k] == 1) != ($NF == "yes") || (tn[k] < 20) != (d[k] == 1)) bad++ }
         END { exit bad || seen != 17 }' "$TMP/wtr/segments.csv" FS=' ' "$TMP/wtr.out" && ok ||
    bad "track --epi: segments.csv and the report disagree on thickening or the flag"
[ "$(grep -c 'id="segment-' "$TMP/wtr/thickening.svg")" -eq 17 ] &&
    [ "$(grep -c 'class="segment dysfunctional"' "$TMP/wtr/thickening.svg")" -eq "$(awk -F, 'NR > 1 && $11 == 1' "$TMP/wtr/segments.csv" | wc -l)" ] &&
    ok || bad "thickening.svg: not 17 segments, or not the CSV's dysfunctional ones"
if command -v python3 >/dev/null 2>&1; then
    python3 - "$TMP/wtr.json" "$TMP/wtr.out" "$TMP/wtr/segments.csv" <<'PY' && ok || bad "track --epi --json: the summary disagrees (see above)"
import csv, json, re, sys
j = json.load(open(sys.argv[1]), parse_constant=lambda c: sys.exit("%s is no JSON" % c))
report = open(sys.argv[2]).read()
m = re.search(r"LV mass +ED (\S+) g, ES (\S+) g", report)
assert m and "%.4g" % j["mass_ed_g"] == m.group(1) and "%.4g" % j["mass_es_g"] == m.group(2), (m and m.groups(), j["mass_ed_g"])
g = re.search(r"global thickening (\S+) %", report)
assert g and "%.1f" % j["thickening_percent"] == g.group(1), (g and g.group(1), j["thickening_percent"])
assert abs(j["thickening_percent"] - 100 * (j["thickness_es_mm"] / j["thickness_ed_mm"] - 1)) < 1e-9
rows = list(csv.DictReader(open(sys.argv[3])))
for s, r in zip(j["segments"], rows):
    for key in ("thickness_ed_mm", "thickness_es_mm", "thickening_percent"):
        assert abs(s[key] - float(r[key])) <= 1e-8 * abs(s[key]), (key, s, r)
    assert s["dysfunctional"] == (r["dysfunctional"] == "1") == (s["thickening_percent"] < j["dysfunctional_thickening_percent"]), s
for f in j["frames"]:
    assert f["epi_file"].endswith("epi_points_%02d.ply" % j["frames"].index(f)) and f["epi_points"] == 3000, f
    assert f["myocardium_ml"] > 0
PY
else
    grep -q '"mass_ed_g": ' "$TMP/wtr.json" && grep -q '"dysfunctional": ' "$TMP/wtr.json" && ok || bad "track --epi --json: no mass or flags"
fi
# stacks: the thickness in the slices' planes (radial), between the outer slices. A tube of 7 slices (z 0..60, 64 points a
# circle): cavity radius 20 -> 15, epicardium 28 -> 25, so 8 -> 10 mm, thickening 25 %, on every slice (up to the
# lids half a spacing beyond the outer slices it would read 19 %)
for f in "ed 20" "es 15" "ed_epi 28" "es_epi 25"; do
    set -- $f
    awk -v r="$2" 'BEGIN { for (z = 0; z <= 60; z += 10) for (i = 0; i < 64; i++)
        printf "%.6f %.6f %d\n", r * cos(6.283185307179586 * i / 64), r * sin(6.283185307179586 * i / 64), z }' \
        >"$TMP/tube_$1.xyz"
done
expect 0 "in the slices' planes, radially from the cavity's centre" track "$TMP/tube_ed.xyz" "$TMP/tube_es.xyz" \
    --epi "$TMP/tube_ed_epi.xyz,$TMP/tube_es_epi.xyz" -o "$TMP/wtube"
awk '/^  wall thickness/ { found = 1; t = $4; e = $7; g = $11 } END { exit !(found && (t - 8) ^ 2 < 0.05 ^ 2 &&
    (e - 10) ^ 2 < 0.05 ^ 2 && (g - 25) ^ 2 < 0.5 ^ 2) }' "$TMP/out" && ok ||
    bad "track --epi on a tube's stacks: $(grep '^  wall thickness' "$TMP/out"), not 8 -> 10 mm, 25 %"
# without --epi: no wall columns, and the epicardial meshes of the earlier run in the reused folder removed
expect 0 "" track "$TMP"/wph/points_00.ply "$TMP"/wph/points_04.ply -o "$TMP/wtr" --septum -1,0,0 --quiet
[ ! -e "$TMP/wtr/epi_frame_00.ply" ] && ! head -n 1 "$TMP/wtr/segments.csv" | grep -q thickness && ok ||
    bad "track without --epi: epicardial meshes left, or wall columns: $(ls "$TMP/wtr")"
# refused up front: a count mismatch, a bad epicardial frame (named), --myocardium-label without --label or on point files
EPI7=$(ls "$TMP"/wph/epi_points_*.ply | head -n 7 | paste -sd, -)
expect 2 "--epi gives 7 epicardial frames, the FRAME inputs 8 frames" track "$TMP"/wph/points_*.ply --epi "$EPI7" -o "$TMP/wno"
expect 2 "--epi takes FILE,FILE,..." track "$PH0" "$PH3" --epi "$TMP/wph/epi_points_00.ply," -o "$TMP/wno"
expect 1 "$TMP/two.xyz (epicardial frame 1): 2 points: a frame needs at least 13" track "$PH0" "$PH3" --epi "$TMP/wph/epi_points_00.ply,$TMP/two.xyz" -o "$TMP/wno"
expect 1 "$TMP/flat.xyz (epicardial frame 0): the points are all in one place" track "$PH0" "$PH3" --epi "$TMP/flat.xyz,$TMP/wph/epi_points_04.ply" -o "$TMP/wno"
expect 1 "$TMP/missing.xyz: cannot open" track "$PH0" "$PH3" --epi "$TMP/wph/epi_points_00.ply,$TMP/missing.xyz" -o "$TMP/wno"
expect 2 "--myocardium-label needs --label" track "$PH0" "$PH3" --myocardium-label 2 -o "$TMP/wno"
expect 2 "--epi and --myocardium-label exclude each other" track "$PH0" "$PH3" --label 3 --myocardium-label 2 --epi "$PH0,$PH3" -o "$TMP/wno"
expect 1 "a point file, and --label applies to volumes only" track "$PH0" "$PH3" --label 3 --myocardium-label 2 -o "$TMP/wno"
[ -e "$TMP/wno" ] && bad "track --epi: a refused run left an output folder" || ok
# a label map (ACDC's labels): a ball of cavity (3) in a shell of myocardium (2), a block of right ventricle (1)
# beside it; ED: radii 10 and 16, ES: 8 and 15: the wall 6 then 7 voxels thick (1 mm), thickening 16.7 %
for f in 0:10:16 1:8:15; do
    awk -v ri="$(echo $f | cut -d: -f2)" -v ro="$(echo $f | cut -d: -f3)" 'BEGIN {
        print "# vtk DataFile Version 3.0\nwall\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 44 40 40"
        print "SPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA 70400\nSCALARS label unsigned_char\nLOOKUP_TABLE default"
        for (k = 0; k < 40; k++) for (j = 0; j < 40; j++) for (i = 0; i < 44; i++) {
            r2 = (i - 19.5) ^ 2 + (j - 19.5) ^ 2 + (k - 19.5) ^ 2
            print (r2 < ri * ri ? 3 : r2 < ro * ro ? 2 : i >= 37 && j > 10 && j < 30 && k > 10 && k < 30 ? 1 : 0) } }' >"$TMP/wall_${f%%:*}.vtk"
done
expect 0 "LV mass          ED" track "$TMP/wall_0.vtk" "$TMP/wall_1.vtk" --label 3 --myocardium-label 2 -o "$TMP/wlab" --apex 0,0,-1 --septum -1,0,0 --json "$TMP/wlab.json"
awk '/^  wall thickness/ { ed = $4; es = $7 } /^  LV mass/ { m = $4 }
     END { pi = 3.14159265358979; truth = 1.05 * 4 / 3 * pi * (16 ^ 3 - 10 ^ 3) / 1000
           exit !((ed - 6) ^ 2 < 0.5 ^ 2 && (es - 7) ^ 2 < 0.5 ^ 2 && (m / truth - 1) ^ 2 < 0.05 ^ 2) }' "$TMP/out" && ok ||
    bad "track --myocardium-label: wall thickness ED, ES not 6, 7 (+-0.5) or the mass not within 5 % of the shell's: $(grep -E 'wall thickness|LV mass' "$TMP/out")"
# examples/study_csv.py: three exams (a sphere shrinking to 0.8 and 0.9 of its radius: EF 48.8 and 27.1 %; one the
# model cannot follow) in a pool of two, one CSV; two shards concatenated hold the same rows
if command -v python3 >/dev/null 2>&1; then
    for e in e1:0.8 e2:0.9 e3:5e-5; do
        mkdir -p "$TMP/study/sub/${e%%:*}"
        cp "$TMP/sphere.xyz" "$TMP/study/sub/${e%%:*}/ed.xyz"
        awk -v f="${e#*:}" '{ printf "%.12g %.12g %.12g\n", $1 * f, $2 * f, $3 * f }' "$TMP/sphere.xyz" >"$TMP/study/sub/${e%%:*}/es.xyz"
    done
    python3 examples/study_csv.py "$TMP/study" -o "$TMP/study.csv" --jobs 2 --sqffd "$SQFFD" -- --mm-per-unit 2 2>"$TMP/err"
    [ $? -eq 1 ] && grep -q "sub/e3: .*did not follow" "$TMP/err" && ok || bad "study_csv: the failed exam not reported: $(cat "$TMP/err")"
    python3 - "$TMP/study.csv" <<'PY' && ok || bad "study_csv: wrong rows (see above)"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["exam"] for r in rows] == ["sub/e1", "sub/e2", "sub/e3"], rows
for r, ef in zip(rows, (100 * (1 - 0.8 ** 3), 100 * (1 - 0.9 ** 3))):
    assert r["status"] == "ok" and abs(float(r["ef_percent"]) - ef) < 1, (r, ef)
    assert r["unit_source"] == "given" and float(r["mm_per_unit"]) == 2 and r["ed_index"] == "0", r
    assert abs(float(r["edv_ml"]) - 8 * 4 / 3 * 3.141592653589793 * 1e3 / 1e3) < 0.02 * 33.5, r
assert rows[2]["status"] == "failed" and "did not follow" in rows[2]["message"] and rows[2]["ef_percent"] == "", rows[2]
PY
    for i in 0 1; do python3 examples/study_csv.py "$TMP/study" --shard $i/2 --sqffd "$SQFFD" -o "$TMP/shard_$i.csv" -- --mm-per-unit 2 2>/dev/null; done
    awk 'FNR > 1 || NR == 1' "$TMP/shard_0.csv" "$TMP/shard_1.csv" | sort >"$TMP/shards.csv"
    sort "$TMP/study.csv" | cmp -s - "$TMP/shards.csv" && ok || bad "study_csv: two shards do not hold the whole study's rows"
    python3 examples/study_csv.py "$TMP/study" --shard 2/2 2>"$TMP/err"
    [ $? -eq 2 ] && grep -q "I must be 0..N-1" "$TMP/err" && ok || bad "study_csv: --shard 2/2 accepted"
else
    echo "cli_test: no python3: examples/study_csv.py not tested"
fi

# PCD clouds (PCL's files): fit, info and track report the NaN pixels dropped; broken files are bad input
PCD=tests/data/pcd_kinect_binary_compressed.pcd
expect 0 "points read      400" fit "$PCD" -o "$TMP/pcd.ply" --iterations 2 --mesh 8
grep -qF "dropped          32 points with NaN coordinates (invalid depth)" "$TMP/out" && ok || bad "fit on a PCD does not report its 32 NaN points"
check_ply "$TMP/pcd.ply"
expect 0 "format      PCD 0.7, binary_compressed" info "$PCD"
for word in "fields      x F4, y F4, z F4, rgba U4" "layout      24 x 18 (organised)" "points      400" \
    "dropped     32 points with NaN coordinates (invalid depth)" "diagonal    3.03106"; do
    grep -qF "$word" "$TMP/out" && ok || bad "info on a PCD lacks '$word'"
done
expect 0 "format      PCD 0.7, ascii, gzip-compressed" info tests/data/pcd_kinect_ascii.pcd.gz
expect 0 "dropped          64 points with NaN coordinates (invalid depth) in 2 frames" \
    track "$PCD" tests/data/pcd_kinect_ascii.pcd.gz -o "$TMP/tpcd" --iterations 2 --frame-iterations 1
head -c 300 "$PCD" >"$TMP/cut.pcd"
expect 1 "$TMP/cut.pcd: 3521 bytes of compressed data, file holds " fit "$TMP/cut.pcd" -o "$TMP/x.ply"
printf 'VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 640\nHEIGHT 480\nDATA binary\n012345678901234567890123' >"$TMP/huge.pcd"
expect 1 "$TMP/huge.pcd: header says 307200 points of 12 bytes each, file holds 24 bytes of data" info "$TMP/huge.pcd"
printf 'FIELDS x y z\nPOINTS 2\nDATA ascii\nnan 1 2\n3 nan 4\n' >"$TMP/holes.pcd"
expect 1 "$TMP/holes.pcd: all 2 points have NaN coordinates (invalid depth)" fit "$TMP/holes.pcd" -o "$TMP/x.ply"

# STL: ASCII and binary (a binary header may start with "solid"), shared vertices merged; broken files: one line
printf 'solid part\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid part\n' >"$TMP/ascii.stl"
expect 0 "triangles   1 (3 vertices, 3 distinct: the points)" info "$TMP/ascii.stl"
grep -q "format      STL, ASCII" "$TMP/out" && ok || bad "info ascii.stl: $(cat "$TMP/out")"
{ printf 'solid but binary'; zeros 64; printf '\002\000\000\000'; zeros 100; } >"$TMP/binary.stl"
expect 0 "triangles   2 (6 vertices, 1 distinct: the points)" info "$TMP/binary.stl"
grep -q "format      STL, binary" "$TMP/out" && ok || bad "info binary.stl: $(cat "$TMP/out")"
{ printf 'solid but binary'; zeros 64; printf '\003\000\000\000'; zeros 100; } >"$TMP/short.stl"
foreign "$TMP/short.stl" "binary STL: 3 triangles take 84 + 50 x 3 = 234 bytes, the file has 184"
sed 's/vertex 1 0 0/vertex nan 0 0/' "$TMP/ascii.stl" >"$TMP/nan.stl"
foreign "$TMP/nan.stl" "facet 0 (line 5): 'nan' is not a finite number"
printf 'solid empty\nendsolid empty\n' >"$TMP/empty.stl"
foreign "$TMP/empty.stl" "ASCII STL without triangles"
# a UV sphere of radius 10: 16 rings of 24 vertices between the poles, 720 triangles, 362 distinct vertices
awk 'function v(i, j,  t, p) { if (i == 0) return "0 0 10"; if (i == 16) return "0 0 -10"
        t = 3.14159265358979 * i / 16; p = 2 * 3.14159265358979 * (j % 24) / 24
        return sprintf("%.6f %.6f %.6f", 10 * sin(t) * cos(p), 10 * sin(t) * sin(p), 10 * cos(t)) }
     function f(a, b, c) { printf " facet normal 0 0 0\n  outer loop\n   vertex %s\n   vertex %s\n   vertex %s\n  endloop\n endfacet\n", a, b, c }
     BEGIN { print "solid sphere"
             for (i = 0; i < 16; i++) for (j = 0; j < 24; j++) {
                 if (i > 0) f(v(i, j), v(i, j + 1), v(i + 1, j + 1))
                 if (i < 15) f(v(i, j), v(i + 1, j + 1), v(i + 1, j)) }
             print "endsolid sphere" }' >"$TMP/sphere.stl"
expect 0 "triangles   720 (2160 vertices, 362 distinct: the points)" info "$TMP/sphere.stl"
expect 0 "points read      362" fit "$TMP/sphere.stl" -o "$TMP/sphere.ply" --iterations 3 --mesh 8
# legacy VTK points: POLYDATA; broken files: one line
printf '# vtk DataFile Version 3.0\nhuge\nASCII\nDATASET POLYDATA\nPOINTS 1000000000000 float\n0 0 0\n' >"$TMP/huge.vtk"
foreign "$TMP/huge.vtk" "POINTS (line 5): 3000000000000 values, the file holds 7 bytes after line 5"
printf '# vtk DataFile Version 3.0\nnan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 nan 0\n' >"$TMP/nan.vtk"
foreign "$TMP/nan.vtk" "POINTS (line 5): value 1 (line 6), 'nan', is not a finite number"
# a legacy VTK volume: an ASCII STRUCTURED_POINTS ball, through --iso and --label
awk 'BEGIN { print "# vtk DataFile Version 3.0\nball\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 16 16 16"
             print "SPACING 1 1 2\nORIGIN 0 0 0\nPOINT_DATA 4096\nSCALARS label unsigned_char\nLOOKUP_TABLE default"
             for (k = 0; k < 16; k++) for (j = 0; j < 16; j++) for (i = 0; i < 16; i++)
                 print ((i - 7.5) ^ 2 + (j - 7.5) ^ 2 + (k - 7.5) ^ 2 < 36 ? 3 : 0) }' >"$TMP/ball.vtk"
expect 0 "format      VTK," info "$TMP/ball.vtk"
grep -q "spacing     1 x 1 x 2" "$TMP/out" && grep -q "values      0 .. 3" "$TMP/out" && ok || bad "info ball.vtk: $(cat "$TMP/out")"
expect 0 "volume           VTK, 1 frame" fit "$TMP/ball.vtk" -o "$TMP/ball.ply" --iso 1.5 --iterations 2 --mesh 8
expect 0 "volume           VTK, 1 frame" fit "$TMP/ball.vtk" -o "$TMP/ball.ply" --label 3 --iterations 2 --mesh 8
sed 's/^DIMENSIONS 16 16 16$/DIMENSIONS 16 16 17/' "$TMP/ball.vtk" >"$TMP/ball17.vtk"
foreign "$TMP/ball17.vtk" "POINT_DATA 4096, but DIMENSIONS 16 x 16 x 17 make 4352 points"

# volumes: fit on a NIfTI iso-surface, info, the outputs re-read
BRAIN=tests/data/KmeansTest_T1UCharRaw.nii.gz
expect 0 "iso-surface      level" fit "$BRAIN" -o "$TMP/brain.vtk" --vtk --ascii --json "$TMP/brain.json" --svg "$TMP/brain.svg" --iterations 5
grep -q "of the largest component, 6000 kept" "$TMP/out" && ok || bad "fit on a volume did not keep 6000 points of the largest component"
head -n 1 "$TMP/brain.vtk" | grep -q '^# vtk DataFile Version' && grep -q '^DATASET POLYDATA$' "$TMP/brain.vtk" &&
    grep -q '^POINTS 8194 ' "$TMP/brain.vtk" && grep -q '^POLYGONS 16384 65536$' "$TMP/brain.vtk" &&
    grep -q '^SCALARS error float 1$' "$TMP/brain.vtk" && ok || bad "brain.vtk: not the VTK polydata expected"
# sqffd's own VTK read back: the mesh's vertices are the points
expect 0 "format      VTK 3.0 POLYDATA, ASCII" info "$TMP/brain.vtk"
grep -q "points      8194" "$TMP/out" && ok || bad "info brain.vtk: not 8194 points: $(cat "$TMP/out")"
expect 0 "points read      8194" fit "$TMP/brain.vtk" -o "$TMP/brain2.vtk" --vtk --iterations 2
expect 0 "format      VTK 3.0 POLYDATA, binary" info "$TMP/brain2.vtk"
grep -q '"format": *"sqffd-model"' "$TMP/brain.json" && grep -q '"control"' "$TMP/brain.json" && ok || bad "brain.json lacks its format or control points"
grep -q '<svg' "$TMP/brain.svg" && tail -c 20 "$TMP/brain.svg" | grep -q '</svg>' && ok || bad "brain.svg is not a whole SVG"
expect 0 "iso-surface      level 60," fit "$BRAIN" -o "$TMP/b60.ply" --iso 60 --sample 500 --all-components --iterations 1
grep -q "crossing points, 500 kept" "$TMP/out" && ok || bad "--iso 60 --sample 500 --all-components not reported"
expect 2 "--iso takes" fit "$BRAIN" -o "$TMP/x.ply" --iso abc
expect 2 "--sample must be" fit "$BRAIN" -o "$TMP/x.ply" --sample 5
expect 1 "no voxel crosses the iso level" fit "$BRAIN" -o "$TMP/x.ply" --iso 1000
expect 0 "dims        128 x 128 x 62, 1 frame" info "$BRAIN"
for word in "NIfTI-1" "spacing" "values      0 .. 255" "affine"; do grep -q "$word" "$TMP/out" && ok || bad "info lacks '$word'"; done
expect 0 "big-endian" info tests/data/anatomical.nii
expect 0 "2 frames" info tests/data/example4d.nii.gz
expect 0 "points      1839" info "$DATA"
expect 2 "one FILE" info
expect 1 "$TMP/missing.nii: cannot open" info "$TMP/missing.nii"
printf 'not a volume\n' >"$TMP/bad.nii"
expect 1 "$TMP/bad.nii: " info "$TMP/bad.nii"
# track from one 4-D volume
expect 0 "ejection fraction" track tests/data/example4d.nii.gz -o "$TMP/t4" --frame-iterations 2 --iterations 5
grep -q '^ *1 *6000 ' "$TMP/out" && ok || bad "the 4-D volume's frame 1 was not tracked"
# --slice-shifts: six circles along a bent centreline, their x jumped by the discrete cubic -5 7 4 -4 -7 5 (no
# quadratic in the slice index explains it) times 0.5: each slice's reported shift is minus its jump
awk 'BEGIN { split("-5 7 4 -4 -7 5", j, " "); for (k = 0; k < 6; k++) for (i = 0; i < 48; i++) {
    a = 6.283185307179586 * i / 48; printf "%.12g %.12g %d\n", 3 + 0.1 * k * k + 0.5 * j[k + 1] + (20 + k) * cos(a), -1 + 0.3 * k + (20 + k) * sin(a), 10 * k } }' >"$TMP/stack.xyz"
expect 0 "slice shifts     6 slices along 0 0 1" fit "$TMP/stack.xyz" -o "$TMP/stack.ply" --slice-shifts --iterations 2
awk 'BEGIN { split("2.5 -3.5 -2 2 3.5 -2.5", w, " ") } $1 == "level" { k++; if ($4 - w[k] > 1e-6 || w[k] - $4 > 1e-6 || $5 > 1e-6 || $5 < -1e-6) bad = 1 }
    END { exit bad || k != 6 }' "$TMP/out" && ok || bad "fit --slice-shifts: shifts not minus the jumps: $(grep level "$TMP/out")"
expect 0 "slice shifts     6 slices" track "$TMP/stack.xyz" "$TMP/stack.xyz" -o "$TMP/ts" --slice-shifts --frame-iterations 1 --iterations 2
# the points column: each frame's 6 x 48 file points, and its 2 x (48 + 24 + 16 + 12) lid points apart
awk '$1 ~ /^[01]$/ && $2 == 288 && $3 == 200 { n++ } END { exit n != 2 }' "$TMP/out" && ok ||
    bad "track of stacks: not 288 points and 200 lid points a frame: $(grep -E '^ +[01] ' "$TMP/out")"
expect 0 "after FFD" fit "$TMP/stack.xyz" -o "$TMP/stack.ply" --no-lids --iterations 2
grep -q "lids " "$TMP/out" && bad "fit --no-lids: lids added" || ok
expect 1 "--slice-shifts: not a short-axis stack" fit "$DATA" -o "$TMP/x.ply" --slice-shifts
expect 2 "option '--slice-shifts' takes no value" fit "$TMP/stack.xyz" -o "$TMP/x.ply" --slice-shifts=1
# the demo: everything it lists exists and reads back
expect 0 "written to $TMP/demo/" demo -o "$TMP/demo"
for f in frame_00.ply frame_15.ply motion.ply segments.csv volumes.csv model.json fig3_error.svg table1_alpha.svg volumes.svg bullseye.svg; do
    [ -s "$TMP/demo/$f" ] && ok || bad "demo did not write $f"
done
check_ply "$TMP/demo/motion.ply"
[ "$(grep -c 'id="segment-' "$TMP/demo/bullseye.svg")" -eq 17 ] && ok || bad "bullseye.svg does not hold 17 segments"
grep -q "Table 1" "$TMP/out" && grep -q "Fig. 3" "$TMP/out" && ok || bad "demo report lacks Table 1 or Fig. 3"

# ---- nothing the user owns is lost or half-written
# an ellipsoid's points (a golden-angle spiral): 400, and 25 for the option boundaries
spiral() { awk -v n="$1" 'BEGIN { for (i = 0; i < n; i++) { z = 1 - 2 * (i + 0.5) / n; r = sqrt(1 - z * z); a = i * 2.399963
    printf "%.9g %.9g %.9g\n", 2 * r * cos(a), r * sin(a), 3 * z } }'; }
spiral 400 >"$TMP/ell.xyz"
spiral 25 >"$TMP/e25.xyz"
mkdir "$TMP/own" && cp "$TMP/ell.xyz" "$TMP/own/scan.xyz" && cp "$TMP/ell.xyz" "$TMP/own/keep.xyz" || exit 1
ln -s scan.xyz "$TMP/own/link.ply" && ln "$TMP/own/scan.xyz" "$TMP/own/hard.ply" || exit 1
# the output is the input: by name, through a symbolic link, through a hard link; the input intact, one line
for o in scan.xyz link.ply hard.ply; do
    expect 1 "the output $TMP/own/$o is the input $TMP/own/scan.xyz (the same file)" fit "$TMP/own/scan.xyz" -o "$TMP/own/$o" --iterations 1 --mesh 8
    [ "$(wc -l <"$TMP/err")" -eq 1 ] && ok || bad "fit -o $o (the input): more than one line"
    cmp -s "$TMP/own/scan.xyz" "$TMP/own/keep.xyz" && ok || bad "fit -o $o overwrote its input"
done
expect 1 "is the input" fit "$TMP/own/scan.xyz" -o "$TMP/x.ply" --json "$TMP/own/hard.ply" --iterations 1 --mesh 8
[ ! -e "$TMP/x.ply" ] && ok || bad "a refused --json left the mesh written"
# two outputs that are one file
expect 1 "the outputs $TMP/own/o.ply and $TMP/own/./o.ply are the same file" fit "$TMP/own/scan.xyz" -o "$TMP/own/o.ply" --points "$TMP/own/./o.ply"
cp "$TMP/own/keep.xyz" "$TMP/own/a.ply" && ln "$TMP/own/a.ply" "$TMP/own/b.ply"
expect 1 "are the same file" fit "$TMP/ell.xyz" -o "$TMP/own/a.ply" --svg "$TMP/own/b.ply"
# outputs are checked before the input is read and fitted: with a bad output, a missing input or one too small
# for a fit is not reached, and nothing is written
expect 1 "$TMP/no/dir/out.ply: cannot create: No such file or directory" fit "$TMP/missing.xyz" -o "$TMP/no/dir/out.ply"
expect 1 "$TMP/no/x.json: cannot create" fit "$TMP/two.xyz" -o "$TMP/own/o.ply" --json "$TMP/no/x.json"
[ ! -e "$TMP/own/o.ply" ] && ok || bad "--json to a bad path left the mesh written"
mkdir "$TMP/own/d"
expect 1 "$TMP/own/d: cannot create: it is a folder" fit "$DATA" -o "$TMP/own/o.ply" --svg "$TMP/own/d" --points "$TMP/own/p.ply"
# a failed run leaves an existing output as it was, and no temporary beside it
cp "$TMP/own/keep.xyz" "$TMP/own/o.ply"
expect 1 "cannot create" fit "$TMP/ell.xyz" -o "$TMP/own/o.ply" --json "$TMP/no/x.json" --iterations 1 --mesh 8
cmp -s "$TMP/own/o.ply" "$TMP/own/keep.xyz" && ok || bad "a failed run changed an existing output"
[ -z "$(ls -A "$TMP/own" | grep '^\.')" ] && ok || bad "temporaries left: $(ls -A "$TMP/own" | grep '^\.')"
# a successful run replaces it whole, keeps a symbolic link (writes its target) and the file's mode
chmod 640 "$TMP/own/o.ply" && ln -s o.ply "$TMP/own/to_o.ply"
expect 0 "" fit "$TMP/ell.xyz" -o "$TMP/own/to_o.ply" --json "$TMP/own/m.json" --iterations 1 --mesh 8 --quiet
[ -L "$TMP/own/to_o.ply" ] && check_ply "$TMP/own/o.ply" && ok || bad "fit -o LINK did not write the link's target"
[ "$(stat -c %a "$TMP/own/o.ply" 2>/dev/null || echo 640)" = 640 ] && ok || bad "fit changed the mode of the file it replaced"
[ -z "$(ls -A "$TMP/own" | grep '^\.')" ] && ok || bad "temporaries left after a run"
# /dev/null as an output is written in place (twice is fine)
expect 0 "" fit "$TMP/ell.xyz" -o /dev/null --points /dev/null --iterations 1 --mesh 8 --quiet
# a report that cannot be written is an error
if [ -w /dev/full ]; then
    "$SQFFD" fit "$TMP/ell.xyz" -o "$TMP/own/full.ply" --iterations 1 --mesh 8 >/dev/full 2>"$TMP/err"
    [ $? -eq 1 ] && grep -q "standard output: write error" "$TMP/err" && ok || bad "fit > /dev/full: not exit 1 with a write error"
    "$SQFFD" --help >/dev/full 2>/dev/null && bad "sqffd --help > /dev/full exits 0" || ok
fi
# a reused output folder: the numbered files of an earlier, longer run are removed, no other file
expect 0 "" phantom -o "$TMP/re" --frames 6 --points 500 --quiet
expect 0 "" phantom -o "$TMP/re" --frames 4 --points 500 --quiet
[ "$(ls "$TMP/re" | tr '\n' ' ')" = "points_00.ply points_01.ply points_02.ply points_03.ply truth.csv " ] && ok ||
    bad "phantom into a reused folder: $(ls "$TMP/re" | tr '\n' ' ')"
mkdir "$TMP/retr" && for f in frame_00.ply frame_04.ply frame_05.ply frame_123.ply frame_5.ply frame_007.ply notes.txt; do
    echo x >"$TMP/retr/$f"; done
expect 0 "" track "$TMP/re/points_00.ply" "$TMP/re/points_01.ply" "$TMP/re/points_02.ply" -o "$TMP/retr" --iterations 2 --frame-iterations 1 --quiet
[ "$(ls "$TMP/retr" | tr '\n' ' ')" = "frame_00.ply frame_007.ply frame_01.ply frame_02.ply frame_5.ply motion.ply notes.txt segments.csv volumes.csv " ] &&
    ok || bad "track into a reused folder: $(ls "$TMP/retr" | tr '\n' ' ')"
check_ply "$TMP/retr/frame_00.ply"
# an input among the files track replaces or removes there is refused before anything is read
cp "$TMP/re/points_03.ply" "$TMP/retr/frame_09.ply"
expect 1 "the input $TMP/retr/frame_09.ply is the output folder's frame_09.ply" track "$TMP/re/points_00.ply" "$TMP/retr/frame_09.ply" -o "$TMP/retr"
[ -e "$TMP/retr/frame_09.ply" ] && ok || bad "track removed its own input"
expect 1 "$TMP/no/dir: cannot make the output folder" track "$TMP/missing.ply" "$DATA" -o "$TMP/no/dir"
expect 2 "at least two are needed" track "$DATA" -o "$TMP/newdir"
[ ! -e "$TMP/newdir" ] && ok || bad "a failed track left the folder it made"

# an interrupted run leaves no temporary (nor the output folder it made) behind, and dies of the signal
mkdir "$TMP/int"
# (a background job of a script ignores SIGINT, which sqffd then leaves ignored: SIGTERM here)
"$SQFFD" fit "$DATA" -o "$TMP/int/o.ply" --json "$TMP/int/o.json" --lattice 8 --iterations 10000 --quiet >/dev/null 2>&1 &
pid=$!
sleep 0.5
kill -TERM $pid 2>/dev/null
wait $pid
st=$?
left=$(ls -A "$TMP/int")
[ -z "$left" ] && ok || bad "an interrupted fit left: $left"
[ $st -eq 143 ] && ok || bad "an interrupted fit exited $st, not 143 (SIGTERM)"
"$SQFFD" track "$DATA" "$DATA" -o "$TMP/int/made" --lattice 8 --iterations 10000 --quiet >/dev/null 2>&1 &
pid=$!
sleep 0.5
kill -TERM $pid 2>/dev/null
wait $pid
[ ! -e "$TMP/int/made" ] && ok || bad "an interrupted track left its folder: $(ls -A "$TMP/int/made")"

# ---- the numeric options: the ends of each range work, beyond them a usage error names the option and the range
expect 2 "--alpha must be in [0, 1e12], not '1e18'" fit "$DATA" -o "$TMP/x.ply" --alpha 1e18
for v in 1e307 2e12 -0.5 -1e-300; do expect 2 "--alpha must be in [0, 1e12]" fit "$DATA" -o "$TMP/x.ply" --alpha "$v"; done
for v in 1e20 100.5; do expect 2 "--model-to-data must be in [0, 100]" fit "$DATA" -o "$TMP/x.ply" --model-to-data "$v"; done
expect 2 "--min-jacobian must be in [-1e6, 1] or 'none', not '1.5'" fit "$DATA" -o "$TMP/x.ply" --min-jacobian 1.5
expect 2 "--iterations must be a whole number in [0, 10000], not '10001'" fit "$DATA" -o "$TMP/x.ply" --iterations 10001
expect 2 "--frame-iterations must be a whole number in [0, 10000]" track "$DATA" "$DATA" -o "$TMP/t" --frame-iterations -1
expect 2 "--noise must be in [0, 0.5], not '0.6'" phantom -o "$TMP/ph" --noise 0.6
# (the largest lattice's 1,536-unknown fold-free system takes 0.3-2 s a fit, 10 s the track: make test
# runs its extreme pair, make check every combination)
for pts in e25 ell; do
    for lat in 2 8; do
        for a in 0 1e-20 1e-9 1e12; do
            for w in 0 100; do
                [ $lat = 8 ] && ! thorough && [ "$pts$a$w" != ell0100 ] && continue
                expect 0 "" fit "$TMP/$pts.xyz" -o "$TMP/x.ply" --alpha $a --model-to-data $w --lattice $lat --iterations 8 --mesh 8 --quiet
            done
        done
    done
    thorough &&
        expect 0 "" fit "$TMP/$pts.xyz" -o "$TMP/x.ply" --min-jacobian -1e6 --lattice 8 --iterations 8 --mesh 8 --quiet
    expect 0 "" fit "$TMP/$pts.xyz" -o "$TMP/x.ply" --min-jacobian -1e6 --lattice 2 --iterations 8 --mesh 8 --quiet
    expect 0 "" fit "$TMP/$pts.xyz" -o "$TMP/x.ply" --min-jacobian 1 --iterations 8 --mesh 8 --quiet
done
expect 0 "" fit "$DATA" -o "$TMP/x.ply" --alpha 1e12 --robust --iterations 8 --mesh 8 --quiet
thorough &&
    expect 0 "" track "$TMP/e25.xyz" "$TMP/ell.xyz" -o "$TMP/tb" --alpha 1e-9 --model-to-data 100 --lattice 8 --iterations 8 --quiet
expect 0 "" track "$TMP/e25.xyz" "$TMP/ell.xyz" -o "$TMP/tb" --alpha 1e-9 --model-to-data 100 --lattice 2 --iterations 8 --quiet
expect 0 "" track "$TMP/e25.xyz" "$TMP/ell.xyz" -o "$TMP/tb" --alpha 1e12 --lattice 2 --iterations 8 --quiet

# ---- messages
expect 1 "$TMP/ell.xyz: a point file, and --iso applies to volumes only" fit "$TMP/ell.xyz" -o "$TMP/x.ply" --iso 3
expect 1 "$TMP/ell.xyz: a point file, and --label applies to volumes only" track "$TMP/ell.xyz" "$TMP/ell.xyz" -o "$TMP/t" --label 1
expect 1 "--all-components applies to volumes only" fit "$TMP/ell.xyz" -o "$TMP/x.ply" --all-components
head -n 12 "$TMP/ell.xyz" >"$TMP/twelve.xyz"
expect 1 "$TMP/twelve.xyz: 12 points; at least 13 are needed" fit "$TMP/twelve.xyz" -o "$TMP/x.ply"
# the note beside the Jacobian bound follows its sign (this fit folds the lattice)
expect 0 "jacobian" fit "$TMP/ell.xyz" -o "$TMP/x.ply" --min-jacobian none --alpha 0 --lattice 4 --iterations 10 --mesh 8
awk '$1 == "jacobian" { n++; if (($2 > 0) != ($0 ~ /> 0, no fold/) || ($2 <= 0) != ($0 ~ /<= 0, the model may fold/)) bad = 1 }
    END { exit bad || n != 1 }' "$TMP/out" && ok || bad "the Jacobian's note does not follow its sign: $(grep jacobian "$TMP/out")"
grep -q "jacobian  *-" "$TMP/out" && ok || bad "the folding fit's Jacobian bound is not negative: $(grep jacobian "$TMP/out")"

echo "cli: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
