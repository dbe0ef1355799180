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
    expect 2 "--lattice takes" fit "$DATA" -o "$TMP/x.ply" --lattice "$v"
done
for v in -1 nan inf 1e400 "" 0.1x; do
    expect 2 "--alpha takes" fit "$DATA" -o "$TMP/x.ply" --alpha "$v"
done
for v in -1 nan inf ""; do
    expect 2 "--model-to-data takes" fit "$DATA" -o "$TMP/x.ply" --model-to-data "$v"
done
for v in 10001 2.5 30x -3 ""; do
    expect 2 "--iterations takes" fit "$DATA" -o "$TMP/x.ply" --iterations "$v"
done
for v in 10001 -1 ""; do
    expect 2 "--coarse-iterations takes" fit "$DATA" -o "$TMP/x.ply" --coarse-iterations "$v"
done
expect 2 "--mesh takes" fit "$DATA" -o "$TMP/x.ply" --mesh 3

# bad input: exit 1 and "FILE: what is wrong"
expect 1 "$TMP/missing.ply: cannot open" fit "$TMP/missing.ply" -o "$TMP/x.ply"
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n1 2\n3 4\n' >"$TMP/noz.ply"
expect 1 "$TMP/noz.ply: vertex element has no 'z' property" fit "$TMP/noz.ply" -o "$TMP/x.ply"
printf '1 2 3\n4 5\n' >"$TMP/short.xyz"
expect 1 "$TMP/short.xyz: line 2: expected 3 numbers" fit "$TMP/short.xyz" -o "$TMP/x.ply"
: >"$TMP/empty.xyz"
expect 1 "$TMP/empty.xyz: file is empty" fit "$TMP/empty.xyz" -o "$TMP/x.ply"
printf '1 2 3\n4 5 6\n' >"$TMP/two.xyz"
expect 1 "$TMP/two.xyz: fit failed: " fit "$TMP/two.xyz" -o "$TMP/x.ply"
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
expect 0 "(the lattice's smallest Bernstein bound" fit "$DATA" -o "$TMP/j.ply" --iterations 3 --mesh 8
expect 0 "after FFD" fit "$DATA" -o "$TMP/j.ply" --min-jacobian none --iterations 3 --mesh 8
for v in 1.5 nan abc ""; do
    expect 2 "--min-jacobian takes" fit "$DATA" -o "$TMP/x.ply" --min-jacobian "$v"
done
expect 0 "iterations       3 coarse + 2 (iteration cap)" fit "$DATA" -o "$TMP/c.ply" --iterations 5 --coarse-iterations 3 --mesh 8
expect 0 "iterations       5 (iteration cap)" fit "$DATA" -o "$TMP/c.ply" --iterations 5 --coarse-iterations 0 --mesh 8
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
expect 2 "--low-motion takes" track "$DATA" "$DATA" -o "$TMP/t" --low-motion 2
expect 2 "--frames takes" phantom -o "$TMP/ph" --frames 1
expect 2 "--low-motion takes" phantom -o "$TMP/ph" --low-motion 0.5,1,2
expect 2 "no output folder" phantom --frames 4
expect 1 "$TMP/missing.ply: cannot open" track "$DATA" "$TMP/missing.ply" -o "$TMP/t"
expect 1 "tracking failed at frame 1" track "$DATA" "$TMP/two.xyz" -o "$TMP/t"
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
LC_ALL=C awk '
    /^property float / { prop[np++] = $3 }
    /^element vertex / { nv = $3 }
    /^end_header/ { body = 1; next }
    body && row < nv {
        row++
        for (k = 0; k < np; k++) v[prop[k]] = $(k + 1)
        if (v["displacement"] < 0 || (v["low_motion"] != 0 && v["low_motion"] != 1) || v["segment"] < 0 || v["segment"] > 17) bad++
        seen[v["segment"]] = 1
        low += v["low_motion"]
    }
    END {
        if (np != 7 || prop[3] != "displacement" || prop[4] != "excursion" || prop[5] != "low_motion" || prop[6] != "segment") exit 1
        for (s = 1; s <= 17; s++) if (!seen[s]) exit 2
        exit (bad > 0 || low == 0) ? 3 : 0
    }' "$TMP/tr/motion.ply" && ok || bad "motion.ply: wrong properties or values (awk status $?)"

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
expect 2 "--sample takes" fit "$BRAIN" -o "$TMP/x.ply" --sample 5
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
grep -q "lids             $((2 * 2 * (48 + 24 + 16 + 12))) points close each frame's stack" "$TMP/out" && ok || bad "track of stacks: lids not 2 x 200: $(grep lids "$TMP/out")"
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

echo "cli: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
