#!/bin/sh
# Prints a C file that holds every code snippet of the given files (README.md,
# sqffd.h), taken from the files themselves, for make snippets to compile.
# What counts as a snippet:
#   - in a Markdown file, every fenced block opened by ```c;
#   - in a C file, the lines under a comment line ending in "QUICK START" or
#     "Example:", from the first non-blank line to the next blank one.
# How they are wrapped: each file's snippets are one function, read as one
# session: every snippet is a block nested in the one before, so it sees what
# the earlier ones declared (and may declare a name again). The names they
# take as given (points, n, ...) are declared in tests/snippets.h. A #line
# before each snippet makes the compiler's messages name the file's own lines.
# Usage: sh tests/snippets.sh README.md sqffd.h > build/snippets.c
LC_ALL=C awk '
function close_session() {
    if (!open) return
    for (; depth > 0; depth--) printf "}"
    printf "\n}\n"
    open = 0
}
FNR == 1 {
    close_session()
    markdown = FILENAME ~ /\.md$/
    name = FILENAME
    gsub(/[^A-Za-z0-9]/, "_", name)
    state = 0 # 0 prose, 1 after a marker, 2 in a snippet
}
function start() {
    if (!open) {
        printf "void snippets_%s(void);\nvoid snippets_%s(void)\n{\n", name, name
        open = 1
    }
    printf "{\n#line %d \"%s\"\n", FNR, FILENAME
    depth++
    state = 2
}
markdown && state == 0 && /^```c[ \t]*$/ { state = 1; next }
markdown && state == 1 { start() }
markdown && state == 2 && /^```/ { state = 0; next }
!markdown && state == 0 && /(QUICK START|Example:)[ \t]*$/ { state = 1; next }
!markdown && state == 1 && !/^[ \t]*$/ { start() }
!markdown && state == 2 && /^[ \t]*$/ { state = 0; next }
state == 2 { print }
END { close_session() }
' "$@" | { printf '/* Made by tests/snippets.sh: the code snippets of %s. */\n#include "snippets.h"\n' "$*"; cat; }
