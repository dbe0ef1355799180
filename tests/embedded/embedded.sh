#!/bin/sh
# make embedded: the sqffd core as Cortex-M7 firmware builds it.
#   usage: sh tests/embedded/embedded.sh BUILD_DIR STACK_BOUND [stack_bound options...]
# Cross-compiles tests/embedded/core.c (the implementation alone) with
# arm-none-eabi-gcc, checks what it needs from outside (libm, memcpy/memset/
# memmove and the helpers listed below, nothing else), reports its .text/
# .rodata/.data/.bss, links tests/embedded/fit_m7.c against it with newlib
# (nosys.specs), runs that program under qemu-arm when it is installed, and
# bounds the stack from gcc's call graph with STACK_BOUND (tests/stack_bound.c,
# built with the host gcc). Installs gcc-arm-none-eabi and
# libnewlib-arm-none-eabi with apt-get when they are missing (root only);
# skips with a message when it cannot. Exit status 1 when a check fails.
set -u
out=${1:?build directory}/embedded
bound=${2:?stack_bound binary}
shift 2
here=$(dirname "$0")
CROSS=arm-none-eabi
CPU_FLAGS="-mcpu=cortex-m7 -mfpu=fpv5-d16 -mfloat-abi=hard -mthumb"
FLAGS="$CPU_FLAGS -Os -ffreestanding -std=c99 -Wall -Wextra"
TEXT_LIMIT=73728 # 72 KB: the fold-free deformation and the stacks' volumes took the core past 64 KB (0.12.0)
mkdir -p "$out"

have_toolchain() {
    command -v $CROSS-gcc >/dev/null 2>&1 || return 1
    libm=$($CROSS-gcc $CPU_FLAGS -print-file-name=libm.a)
    [ -f "$libm" ]
}

if ! have_toolchain; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "embedded: installing gcc-arm-none-eabi and libnewlib-arm-none-eabi (apt-get; log in $out/apt.log)"
        { apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y gcc-arm-none-eabi libnewlib-arm-none-eabi; } \
            >"$out/apt.log" 2>&1 || { tail -n 5 "$out/apt.log"; echo "embedded: skipped: apt-get could not install the arm-none-eabi toolchain"; exit 0; }
    fi
    have_toolchain || { echo "embedded: skipped: arm-none-eabi-gcc with newlib's libm not installed (Debian: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi; needs root)"; exit 0; }
fi
echo "== embedded: $($CROSS-gcc --version | head -n 1)"
echo "   flags: $CPU_FLAGS -Os -ffreestanding"
fail=0

# ---- the core object
$CROSS-gcc $FLAGS -ffunction-sections -fdata-sections -fcallgraph-info=su -fstack-usage \
    -c "$here/core.c" -o "$out/core.o" || exit 1
$CROSS-gcc $FLAGS -DNDEBUG -ffunction-sections -fdata-sections -c "$here/core.c" -o "$out/core_ndebug.o" || exit 1

# What the core may need from outside:
#   - libm: every function newlib's libm.a (this multilib) defines;
#   - memcpy, memset, memmove (the core's only libc calls);
#   - __assert_func: newlib's assert() hook (glibc's is __assert_fail, which
#     check-symbols allows on the host); gone with NDEBUG or SQFFD_ASSERT;
#   - __aeabi_*: the ARM EABI run-time helpers from libgcc (64-bit integer
#     division and shifts, double <-> 64-bit integer conversions, which
#     Cortex-M7's FPv5 has no instruction for; __aeabi_memcpy and friends).
#     They are part of the compiler's own runtime, needed by any C code.
# Anything else (malloc, printf, errno hooks, ...) fails.
allowed_libm=$($CROSS-nm -g --defined-only "$libm" 2>/dev/null | awk 'NF == 3 && $2 ~ /[TW]/ {print $3}' | sort -u)
undefined=$($CROSS-nm -u "$out/core.o" | awk '{print $NF}' | sort -u)
bad=""; from_libm=""; helpers=""; from_libc=""
for s in $undefined; do
    case $s in
        memcpy|memset|memmove|__assert_func) from_libc="$from_libc $s" ;;
        __aeabi_*) helpers="$helpers $s" ;;
        *) if echo "$allowed_libm" | grep -qx "$s"; then from_libm="$from_libm $s"; else bad="$bad $s"; fi ;;
    esac
done
echo "   core needs: libm:${from_libm:- none}"
echo "               libc:${from_libc:- none}; EABI helpers:${helpers:- none}"
if [ -n "$bad" ]; then
    echo "FAIL embedded: the core needs symbols outside libm and the allowed helpers:$bad"
    fail=1
fi
ndebug_undefined=$($CROSS-nm -u "$out/core_ndebug.o" | awk '{print $NF}' | grep -v -x -e memcpy -e memset -e memmove | grep -v '^__aeabi_' \
    | while read -r s; do echo "$allowed_libm" | grep -qx "$s" || echo "$s"; done)
[ -z "$ndebug_undefined" ] || { echo "FAIL embedded: with NDEBUG the core still needs:" $ndebug_undefined; fail=1; }

# ---- sizes (section sums of the object: code, read-only data, data, zero-initialised data)
sizes() {
    $CROSS-size -A "$1" | awk '
        $1 ~ /^\.text/   {t += $2}
        $1 ~ /^\.rodata/ {r += $2}
        $1 ~ /^\.data/   {d += $2}
        $1 ~ /^\.bss/ || $1 == "COMMON" {b += $2}
        END {printf "%d %d %d %d\n", t, r, d, b}'
}
read -r text rodata data bss <<EOF
$(sizes "$out/core.o")
EOF
read -r ntext nrodata ndata nbss <<EOF
$(sizes "$out/core_ndebug.o")
EOF
printf '   core.o: .text %d  .rodata %d  .data %d  .bss %d bytes  (NDEBUG: .text %d  .rodata %d)\n' \
    "$text" "$rodata" "$data" "$bss" "$ntext" "$nrodata"
if [ "$text" -gt $TEXT_LIMIT ]; then echo "FAIL embedded: core .text $text bytes > $TEXT_LIMIT"; fail=1; fi
if [ "$data" -ne 0 ] || [ "$bss" -ne 0 ]; then echo "FAIL embedded: the core has writable data (.data $data, .bss $bss bytes)"; fail=1; fi

# ---- a firmware-style program: static arrays, newlib, link only
if $CROSS-gcc $FLAGS -ffunction-sections -fdata-sections -c "$here/fit_m7.c" -o "$out/fit_m7.o" &&
   $CROSS-gcc $CPU_FLAGS --specs=nosys.specs -Wl,--gc-sections -Wl,-Map="$out/fit_m7.map" \
       "$out/fit_m7.o" "$out/core.o" -lm -o "$out/fit_m7.elf" 2>"$out/link.log"; then
    read -r etext edata ebss <<EOF
$($CROSS-size "$out/fit_m7.elf" | awk 'NR == 2 {print $1, $2, $3}')
EOF
    echo "   fit_m7.elf (sqffd_fit + newlib libm, --gc-sections): text $etext  data $edata  bss $ebss bytes: links"
    grep -i 'warning' "$out/link.log" | sed 's/^/   /'
else
    cat "$out/link.log"
    echo "FAIL embedded: fit_m7 does not link against the core and newlib's libm"
    fail=1
fi

# ---- run it under qemu-arm (Linux user mode; installed with apt-get when missing and
# root): the Cortex-M7 code runs unchanged on qemu's ARMv8-A CPU; Linux system calls
# replace semihosting.
if ! command -v qemu-arm >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "embedded: installing qemu-user (apt-get; log in $out/apt_qemu.log)"
    { apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y qemu-user; } >"$out/apt_qemu.log" 2>&1 \
        || tail -n 5 "$out/apt_qemu.log"
fi
if command -v qemu-arm >/dev/null 2>&1; then
    if $CROSS-gcc $FLAGS -DFIT_M7_QEMU -c "$here/fit_m7.c" -o "$out/fit_m7_qemu.o" &&
       $CROSS-gcc $CPU_FLAGS --specs=nosys.specs -nostartfiles "$out/fit_m7_qemu.o" "$out/core.o" -lm \
           -o "$out/fit_m7_qemu.elf" 2>"$out/link_qemu.log"; then
        timeout 600 qemu-arm -cpu max "$out/fit_m7_qemu.elf" >"$out/fit_m7_qemu.log" 2>&1
        rc=$?
        sed 's/^/   /' "$out/fit_m7_qemu.log"
        if [ $rc -ne 0 ]; then echo "FAIL embedded: fit_m7 under qemu-arm exited with $rc"; fail=1; fi
    else
        cat "$out/link_qemu.log"
        echo "FAIL embedded: the qemu variant of fit_m7 does not link"
        fail=1
    fi
else
    echo "   fit_m7: not run (qemu-arm not installed; Debian: apt-get install qemu-user; needs root)"
fi

# ---- stack, from the Cortex-M7 call graph
"$bound" --brief --title "stack, Cortex-M7 -Os" "$@" "$out/core.ci" >"$out/stack.txt" 2>&1
rc=$?
cat "$out/stack.txt"
if [ $rc -ne 0 ]; then echo "FAIL embedded: stack limits (report above; every frame: $out/core.su)"; fail=1; fi

# the measured stack of the run against the bound (libm's own frames are not in the bound)
measured=$(sed -n 's/.*sqffd_fit used \([0-9]*\) bytes of stack.*/\1/p' "$out/fit_m7_qemu.log" 2>/dev/null)
bound_fit=$(awk '($1 == "ok" || $1 == "FAIL") && $2 == "sqffd_fit" {print $3}' "$out/stack.txt")
if [ -n "$measured" ] && [ -n "$bound_fit" ]; then
    if [ "$measured" -le "$bound_fit" ]; then
        echo "   sqffd_fit stack on Cortex-M7: measured $measured bytes <= bound $bound_fit bytes"
    else
        echo "   warning: sqffd_fit measured $measured bytes > its bound $bound_fit bytes (libm's frames are not counted: if the excess is more than a few hundred bytes, the call graph misses a call)"
    fi
fi

[ $fail -eq 0 ] && echo "embedded: ok"
exit $fail
