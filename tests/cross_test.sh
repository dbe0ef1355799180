#!/bin/sh
# make test-cross: the unit tests built with cross compilers and run under
# qemu user mode: 32-bit ARM (armhf, little-endian) and a big-endian target
# (s390x, 64-bit; 32-bit powerpc when s390x cannot be had).
#   usage: sh tests/cross_test.sh BUILD_DIR SOURCES...   (the core and every test file: make's UNIT_SRC)
# Each binary is linked -static (qemu-user then needs no sysroot) and must end
# with "N passed, 0 failed". Missing compilers, C libraries and qemu are
# installed with apt-get (root only); a target that cannot be had is skipped
# with a message. Run from anywhere: the tests' data paths are relative to the
# repository root, so the binaries run there. Exit status 1 when a target's
# tests fail (or do not build).
set -u
cd "$(dirname "$0")/.." || exit 1
out=${1:?build directory}/cross
shift
sources="$*"
mkdir -p "$out"
fail=0
ran=0
apt_updated=0

# target name | compiler | qemu | Debian packages | description
targets='armhf|arm-linux-gnueabihf-gcc|qemu-arm|gcc-arm-linux-gnueabihf libc6-dev-armhf-cross qemu-user|32-bit ARM (armhf, little-endian)
s390x|s390x-linux-gnu-gcc|qemu-s390x|gcc-s390x-linux-gnu libc6-dev-s390x-cross qemu-user|s390x (64-bit, big-endian)
powerpc|powerpc-linux-gnu-gcc|qemu-ppc|gcc-powerpc-linux-gnu libc6-dev-powerpc-cross qemu-user|powerpc (32-bit, big-endian)'

have() { # compiler, qemu: both present, and the compiler has a static libc
    command -v "$1" >/dev/null 2>&1 && command -v "$2" >/dev/null 2>&1 && [ -f "$("$1" -print-file-name=libc.a)" ]
}

apt_install() { # packages...
    [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 || return 1
    echo "test-cross: installing $* (apt-get; log in $out/apt.log)"
    if [ $apt_updated -eq 0 ]; then apt-get update </dev/null >>"$out/apt.log" 2>&1 || return 1; apt_updated=1; fi
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@" </dev/null >>"$out/apt.log" 2>&1
}

# Build every target that can be had (the powerpc fallback only without
# s390x), then run them all at once (qemu is single-threaded; s390x is the
# slow one, about 25 minutes on 2 cores), then judge each log.
big_endian=0
runs=""
while IFS='|' read -r name cc qemu packages what <&3; do
    if [ "$name" = powerpc ] && [ $big_endian -eq 1 ]; then continue; fi
    if ! have "$cc" "$qemu"; then
        # shellcheck disable=SC2086
        apt_install $packages || true
        if ! have "$cc" "$qemu"; then
            echo "test-cross: $name skipped: $cc, its static C library or $qemu not installed (Debian: apt-get install $packages; needs root)"
            continue
        fi
    fi
    [ "$name" = armhf ] || big_endian=1
    echo "== unit tests on $what: $($cc --version | head -n 1), $($qemu --version | head -n 1)"
    # shellcheck disable=SC2086
    if ! $cc -O2 -std=c99 -Wall -Wextra -static -o "$out/sqffd_tests_$name" $sources -lm >"$out/build_$name.log" 2>&1; then
        grep -m 20 'error' "$out/build_$name.log"
        echo "FAIL test-cross: $name: the unit tests do not build ($(grep -c 'error' "$out/build_$name.log") error lines; whole log: $out/build_$name.log)"
        fail=1
        continue
    fi
    grep -i 'warning' "$out/build_$name.log" | sed 's/^/   /'
    rm -f "$out/unit_$name.log" "$out/unit_$name.rc"
    { timeout 3600 "$qemu" "$out/sqffd_tests_$name" </dev/null >"$out/unit_$name.log" 2>&1; echo $? >"$out/unit_$name.rc"; } &
    runs="$runs $name"
done 3<<EOF
$targets
EOF
[ -n "$runs" ] && echo "test-cross: running$runs under qemu (logs: $out/unit_*.log)"
wait
for name in $runs; do
    rc=$(cat "$out/unit_$name.rc")
    last=$(tail -n 1 "$out/unit_$name.log")
    ran=$((ran + 1))
    if [ "$rc" -eq 0 ] && echo "$last" | grep -Eq '^[0-9]+ passed, 0 failed$'; then
        echo "$name: $last"
    else
        # every failing case with its messages (the indented lines the runner prints before it)
        awk '/^    /{held = held $0 "\n"; next} /^FAIL /{printf "%s%s\n", held, $0} {held = ""}' "$out/unit_$name.log"
        [ "$rc" -gt 1 ] && tail -n 5 "$out/unit_$name.log"
        echo "FAIL test-cross: $name: $last (exit status $rc; whole log: $out/unit_$name.log)"
        fail=1
    fi
done
[ $ran -gt 0 ] || [ $fail -ne 0 ] || echo "test-cross: no target could run"
[ $fail -eq 0 ] && [ $ran -gt 0 ] && echo "test-cross: ok"
exit $fail
