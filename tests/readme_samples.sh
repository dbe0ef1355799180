#!/bin/sh
# README.md's sample outputs against what the programs print now (make cli-test), or rewritten from
# it (make readme-samples). A sample is a fenced block just after a marker line:
#   <!-- sample -->          the block is a session: each "$ COMMAND" line, then what it prints
#   <!-- sample: COMMAND --> the block is what COMMAND prints (COMMAND hidden)
# Commands run with sh in a scratch folder holding links to tests/ and the build folder (build/),
# the build folder first on PATH; only stdout is compared. In a block, a line "..." (any
# indentation) stands for any number of lines; the lines between two of them are found in the
# output by their text with the numbers masked, so a rewrite keeps the elisions and refreshes the
# numbers. Timings are masked in both: a number before "ms", every number of a "time" line, and
# the ms column of stream_fit's table. `usage CMD...` prints each sqffd command's usage line
# (its --help's first), wrapped at 108 columns.
# usage: sh tests/readme_samples.sh [--write] BUILD_DIR [README.md]
write=0
[ "$1" = --write ] && { write=1; shift; }
build=$(cd "${1:?usage: readme_samples.sh [--write] BUILD_DIR [README.md]}" && pwd) || exit 1
readme=${2:-README.md}
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d "${TMPDIR:-/tmp}/sqffd_samples.XXXXXX") || exit 1
trap 'rm -rf "$scratch"' EXIT
mkdir "$scratch/run" && ln -s "$repo/tests" "$scratch/run/tests" && ln -s "$build" "$scratch/run/build"

# timings masked (both sides of every comparison)
mask() {
    sed -E -e 's/ *[0-9][0-9.]* ms/ # ms/g' -e '/^ *time /s/ *[0-9][0-9.]*/ #/g' \
        -e 's/^( *[0-9]+ +[0-9]+) +[0-9.]+( +[0-9]+ +[0-9.]+ *)$/\1 #\2/'
}
# the output of one sample command, in the scratch folder
run() {
    (cd "$scratch/run" && PATH="$build:$PATH" sh -c "
        usage() { for c in \"\$@\"; do sqffd \"\$c\" --help | sed -n 's/^usage: //p' | awk '{
            line = \"\"; n = split(\$0, w, \" \")
            for (i = 1; i <= n; i++) {
                if (line != \"\" && length(line) + 1 + length(w[i]) > 108) { print line; line = \"          \" w[i] }
                else line = line == \"\" ? w[i] : line \" \" w[i]
            }
            print line }'; done; }
        $1" 2>/dev/null)
}
# the expected lines ($2) rewritten from the output ($1): the elisions kept, each run of lines
# between them replaced by the output's lines from where its first line is found (numbers masked
# but the first; else all), the last run by the output's last lines; a run not found is kept as
# it is (the comparison then shows it)
refresh() {
    awk -v expected="$2" '
        function key(s) { gsub(/[-+]?[0-9][0-9.e+-]*/, "#", s); return s }
        function key1(s,   t) { # the first number kept: a table row by its index
            if (!match(s, /[-+]?[0-9][0-9.e+-]*/)) return s
            t = substr(s, RSTART + RLENGTH); return substr(s, 1, RSTART + RLENGTH - 1) key(t)
        }
        { out[++n] = $0 }
        END {
            m = 0; while ((getline line < expected) > 0) want[++m] = line
            if (m == 0) for (k = 1; k <= n; k++) print out[k]  # (an empty block: the whole output)
            at = 1; i = 1
            while (i <= m) {
                if (want[i] ~ /^ *\.\.\. *$/) { print want[i]; elided = 1; i++; continue }
                for (j = i; j <= m && want[j] !~ /^ *\.\.\. *$/; j++) {}
                start = 0
                if (!elided) start = at
                else if (j > m) start = n - (j - i) + 1 >= at ? n - (j - i) + 1 : 0  # the last run: the end
                else {
                    for (k = at; k <= n && !start; k++) if (key1(out[k]) == key1(want[i])) start = k
                    for (k = at; k <= n && !start; k++) if (key(out[k]) == key(want[i])) start = k
                }
                if (!elided && j > m) { for (k = at; k <= n; k++) print out[k]; at = n + 1 }  # a whole output
                else if (start) { for (k = start; k < start + j - i && k <= n; k++) print out[k]; at = start + j - i }
                else for (k = i; k < j; k++) print want[k]
                elided = 0; i = j
            }
        }' "$1"
}

# the samples: block N's marker command (or empty) in $scratch/N.cmd, its lines in $scratch/N.block
awk -v dir="$scratch" '
    state == 2 && /^```/ { state = 0; next }
    state == 2 { print > (dir "/" n ".block"); next }
    state == 1 { if ($0 !~ /^```/) { print "readme-samples: line " NR ": no fenced block after the sample marker" > "/dev/stderr"; exit 1 }
                 state = 2; printf "" > (dir "/" n ".block"); next }
    /^<!-- sample(: .*)? -->$/ { n++; state = 1; c = ""
                                 if ($0 ~ /^<!-- sample: /) { c = substr($0, 14); sub(/ -->$/, "", c) }
                                 printf "%s", c > (dir "/" n ".cmd") }
    END { print n + 0 > (dir "/count") }' "$readme" || exit 1
count=$(cat "$scratch/count")
[ "$count" -gt 0 ] || { echo "readme-samples: no sample in $readme"; exit 1; }
# a sample's command must succeed (its stderr shown)
failed() {
    echo "readme-samples: sample $b of $readme: '$1' failed:"
    (cd "$scratch/run" && PATH="$build:$PATH" sh -c "$1" 2>&1 >/dev/null | sed -n '1,5p')
    exit 1
}
bad=0 b=1
while [ "$b" -le "$count" ]; do
    blk="$scratch/$b.block" new="$scratch/$b.new"
    : > "$new"
    if [ -s "$scratch/$b.cmd" ]; then
        run "$(cat "$scratch/$b.cmd")" > "$scratch/out" || failed "$(cat "$scratch/$b.cmd")"
        refresh "$scratch/out" "$blk" > "$new"
    else # a session: each "$ " line's output refreshed in its section
        awk -v dir="$scratch" '/^\$ /{ s++ } { print > (dir "/section." (s + 0)) }' "$blk"
        s=0
        [ -f "$scratch/section.0" ] && cat "$scratch/section.0" >> "$new"
        while [ -f "$scratch/section.$((s + 1))" ]; do
            s=$((s + 1))
            sed -n 1p "$scratch/section.$s" >> "$new"
            sed 1d "$scratch/section.$s" > "$scratch/expected"
            command=$(sed -n '1s/^\$ //p' "$scratch/section.$s")
            run "$command" > "$scratch/out" || failed "$command"
            refresh "$scratch/out" "$scratch/expected" >> "$new"
        done
        rm -f "$scratch"/section.*
    fi
    if ! mask < "$blk" > "$scratch/a" || ! mask < "$new" > "$scratch/b" || ! cmp -s "$scratch/a" "$scratch/b"; then
        if [ $write -eq 0 ]; then
            echo "readme-samples: sample $b of $readme ($(cat "$scratch/$b.cmd"; [ -s "$scratch/$b.cmd" ] || sed -n 1p "$blk")) differs from the output (- README, + now; make readme-samples rewrites it):"
            diff "$scratch/a" "$scratch/b" | sed -n '1,20p'
            bad=1
        fi
    fi
    b=$((b + 1))
done
if [ $write -eq 1 ]; then # each block replaced by its .new
    awk -v dir="$scratch" '
        state == 2 && /^```/ { while ((getline line < (dir "/" n ".new")) > 0) print line; print; state = 0; next }
        state == 2 { next }
        state == 1 { print; state = 2; next }
        /^<!-- sample(: .*)? -->$/ { n++; state = 1 }
        { print }' "$readme" > "$scratch/readme" && cp "$scratch/readme" "$readme" && echo "readme-samples: $count samples of $readme rewritten"
    exit 0
fi
[ $bad -eq 0 ] && echo "readme samples: the $count sample outputs of $readme are what the programs print (timings masked)"
exit $bad
