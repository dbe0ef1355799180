#!/bin/sh
# The "API BY LAYER" list of sqffd.h's top comment against the header's declarations: every name
# it lists is declared (a function; on a "types:" line, a type), and every public function
# (SQFFD_DEF) is listed. The list's shorthand is expanded as the comment defines it:
# X(_a, _b) is X, X_a and X_b; X/_a (or X / _a) is X and X with its last word replaced by _a.
# usage: sh tests/check_doc_names.sh [sqffd.h]
header=${1:-sqffd.h}
tmp=${TMPDIR:-/tmp}/sqffd_doc_names.$$
trap 'rm -f "$tmp".*' EXIT
# the declarations: everything before the implementation
sed -n '1,/^#endif \/\* SQFFD_H \*\//p' "$header" > "$tmp.api"
sed -n 's/^SQFFD_DEF .*[ *]\(sqffd_[a-z0-9_]*\)(.*/\1/p' "$tmp.api" | sort -u > "$tmp.functions"
{ sed -n 's/^} \(sqffd_[a-z0-9_]*\);.*/\1/p' "$tmp.api"
  sed -n 's/^typedef .*[ *(]\(sqffd_[a-z0-9_]*\)[;)].*/\1/p' "$tmp.api"; } | sort -u > "$tmp.types"
# the list: from its heading to the comment's next section
sed -n '/^   API BY LAYER/,/^   [A-Z][A-Z]*:/p' "$header" | sed '1d;$d' > "$tmp.block"
if [ ! -s "$tmp.block" ]; then echo "check-doc-names: no API BY LAYER list in $header"; exit 1; fi
expand_names() {
    awk '{
        line = $0
        while (match(line, /sqffd_[a-z0-9_]+/)) {
            name = substr(line, RSTART, RLENGTH); line = substr(line, RSTART + RLENGTH); print name
            if (match(line, /^\(_[a-z0-9_, ]*\)/)) {          # X(_a, _b)
                n = split(substr(line, 2, RLENGTH - 2), part, /[ ,]+/)
                for (i = 1; i <= n; i++) if (part[i] != "") print name part[i]
                line = substr(line, RLENGTH + 1)
            }
            stem = name; sub(/_[a-z0-9]+$/, "", stem)
            while (match(line, /^ *\/ *_[a-z0-9_]+/)) {        # X/_a
                suffix = substr(line, 1, RLENGTH); sub(/^[ \/]*/, "", suffix); print stem suffix
                line = substr(line, RLENGTH + 1)
            }
        }
    }'
}
grep -v '^ *types:' "$tmp.block" | expand_names | sort -u > "$tmp.listed"
grep '^ *types:' "$tmp.block" | sed 's/([^)]*)//g' | expand_names | sort -u > "$tmp.listed_types"
bad=0
for name in $(comm -23 "$tmp.listed" "$tmp.functions"); do
    if grep -qx "$name" "$tmp.types"; then echo "check-doc-names: $name is a type, listed as a function (put it on a types: line)"
    else echo "check-doc-names: the list names $name, which is not a declared function"; fi
    bad=1
done
for name in $(comm -23 "$tmp.listed_types" "$tmp.types"); do
    echo "check-doc-names: the list names the type $name, which is not declared"; bad=1
done
for name in $(comm -13 "$tmp.listed" "$tmp.functions"); do
    echo "check-doc-names: $name is declared but not in the API BY LAYER list"; bad=1
done
[ $bad -eq 0 ] && echo "doc names: the $(wc -l < "$tmp.listed") functions and $(wc -l < "$tmp.listed_types") types of the API BY LAYER list are the header's $(wc -l < "$tmp.functions") public functions"
exit $bad
