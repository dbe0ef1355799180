#!/bin/sh
# The SQFFD_MAX_LATTICE guard, derived from the header itself:
#   1. the lattice-dependent public functions are every SQFFD_DEF declaration
#      whose prototype names a lattice-dependent type (a struct whose body
#      mentions SQFFD_MAX_LATTICE, in code or in a field's comment such as
#      "2..SQFFD_MAX_LATTICE", or embeds such a struct) or whose own comment
#      mentions SQFFD_MAX_LATTICE; the rename list of THE LATTICE GUARD in
#      sqffd.h must be exactly those functions;
#   2. for each of them, tests/check_use.c built with SQFFD_MAX_LATTICE 6 and
#      referencing only that function (CHECK_USE_FUNCTIONS) fails to link
#      against an implementation built with the default, naming
#      <function>_lattice6;
#   3. controls: the same units at the default bound link (one unit with all
#      of them), and a unit at bound 6 referencing every other public
#      function links (those do not depend on the bound).
# Usage: tests/check_lattice_guard.sh CC IMPLEMENTATION_OBJECT WORK_DIR
#   IMPLEMENTATION_OBJECT: tests/check_header.c compiled with the default bound.
cc=${1:?usage: check_lattice_guard.sh CC IMPLEMENTATION_OBJECT WORK_DIR}
impl=${2:?usage: check_lattice_guard.sh CC IMPLEMENTATION_OBJECT WORK_DIR}
work=${3:?usage: check_lattice_guard.sh CC IMPLEMENTATION_OBJECT WORK_DIR}
dir=$(dirname "$0")
header=$dir/../sqffd.h
mkdir -p "$work" || exit 1
fail() { echo "lattice guard: $*"; exit 1; }

# "D name" for every public function, D = 1 when it depends on the bound.
awk '
/^#ifdef SQFFD_IMPLEMENTATION/ { exit }
proto != "" {
    proto = proto " " $0
    if ($0 ~ /;/) { protos[++np] = proto; docs[np] = doc; proto = "" }
    next
}
body != "" {
    body = body " " $0
    if ($0 ~ /^} [a-z_0-9]+;/) { name = $2; sub(/;.*/, "", name); types[name] = body; body = "" }
    next
}
/^typedef struct [a-z_0-9]+ \{/ { body = $0; next }
/^SQFFD_DEF / {
    doc = (comment_end == NR - 1) ? comment : ""
    proto = $0
    if ($0 ~ /;/) { protos[++np] = proto; docs[np] = doc; proto = "" }
    next
}
in_comment { comment = comment " " $0; if ($0 ~ /\*\//) { in_comment = 0; comment_end = NR }; next }
/^\/\*/ { comment = $0; if ($0 ~ /\*\//) comment_end = NR; else in_comment = 1; next }
function mentions(text, word) { return text ~ ("(^|[^a-z_0-9])" word "([^a-z_0-9]|$)") }
END {
    for (t in types) dep[t] = types[t] ~ /SQFFD_MAX_LATTICE/
    do {
        changed = 0
        for (t in types) if (!dep[t]) for (u in types) if (dep[u] && mentions(types[t], u)) { dep[t] = 1; changed = 1 }
    } while (changed)
    for (i = 1; i <= np; i++) {
        p = protos[i]
        name = p; sub(/\(.*/, "", name); sub(/.*[^a-z_0-9]/, "", name)
        d = docs[i] ~ /SQFFD_MAX_LATTICE/
        for (t in types) if (dep[t] && mentions(p, t)) d = 1
        print d, name
    }
}' "$header" > "$work/functions" || fail "cannot parse $header"
[ -s "$work/functions" ] || fail "no SQFFD_DEF declarations found in $header"
awk '$1 == 1 { print $2 }' "$work/functions" | sort > "$work/dependent"
awk '$1 == 0 { print $2 }' "$work/functions" | sort > "$work/independent"
sed -n 's/^#define \(sqffd_[a-z_0-9]*\) SQFFD__LATTICE(\1)$/\1/p' "$header" | sort > "$work/renamed"
[ -z "$(uniq -d "$work/renamed")" ] || fail "renamed twice: $(uniq -d "$work/renamed" | tr '\n' ' ')"
missing=$(comm -23 "$work/dependent" "$work/renamed" | tr '\n' ' ')
extra=$(comm -13 "$work/dependent" "$work/renamed" | tr '\n' ' ')
[ -z "$missing" ] || fail "depend on SQFFD_MAX_LATTICE but are not renamed: $missing"
[ -z "$extra" ] || fail "renamed but not lattice-dependent public functions: $extra"

# 2. each dependent function, alone, across a mismatch: no link.
n=0
for f in $(cat "$work/dependent"); do
    "$cc" -std=c99 -DSQFFD_MAX_LATTICE=6 -DCHECK_USE_FUNCTIONS="(check_use_fn)$f" -c "$dir/check_use.c" -o "$work/use.o" ||
        fail "check_use.c does not compile referencing $f"
    if "$cc" "$work/use.o" "$impl" -o "$work/use" -lm > "$work/link.log" 2>&1; then
        fail "a unit built with SQFFD_MAX_LATTICE 6 calling $f links against the default build"
    fi
    grep -q "${f}_lattice6" "$work/link.log" || { cat "$work/link.log"; fail "the failed link does not name ${f}_lattice6"; }
    n=$((n + 1))
done

# 3. controls: every dependent function at the default bound, every other one at bound 6, link.
for bound in 8 6; do
    list=$work/dependent
    [ $bound = 6 ] && list=$work/independent
    refs=$(sed 's/^/(check_use_fn)/' "$list" | tr '\n' ',')
    "$cc" -std=c99 -DSQFFD_MAX_LATTICE=$bound -DCHECK_USE_FUNCTIONS="$refs" -c "$dir/check_use.c" -o "$work/use.o" &&
        "$cc" "$work/use.o" "$impl" -o "$work/use" -lm || fail "the control unit (bound $bound) does not link"
done
echo "lattice guard: $n of $(wc -l < "$work/functions") public functions depend on SQFFD_MAX_LATTICE, all renamed; each alone fails to link across a mismatch"
