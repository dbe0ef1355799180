#!/bin/sh
# Packaging check: `make install` into a temporary DESTDIR, then a tiny consumer
# built with the installed sqffd.pc (pkg-config, or the file read by hand when
# pkg-config is missing) and, when cmake is present, through add_subdirectory,
# FetchContent (SOURCE_DIR) and find_package after `cmake --install`.
# Usage: sh tests/package_test.sh   (from the repository root; temp files in build/package_test)
ROOT=$(pwd)
T=$ROOT/build/package_test
CC=${CC:-cc}
unset MAKEFLAGS MFLAGS   # the makes below are not part of the caller's job server
rm -rf "$T" && mkdir -p "$T/consumer" || exit 1

fail() {
    echo "FAIL package: $1"
    [ -n "$2" ] && [ -f "$2" ] && tail -n 30 "$2"
    exit 1
}

version=$(sed -n 's/^#define SQFFD_VERSION_STRING "\(.*\)"$/\1/p' sqffd.h)
[ -n "$version" ] || fail "no SQFFD_VERSION_STRING in sqffd.h"

# The consumer: the whole implementation compiled in (its libm calls must link), real calls checked.
cat > "$T/consumer/main.c" <<'EOF'
#define SQFFD_IMPLEMENTATION
#include <sqffd.h>
#include <stdio.h>
#include <string.h>

int main(void)
{
    sqffd_fit_options opt = sqffd_fit_options_default();
    if (opt.lattice[0] != 5 || opt.max_iterations <= 0 || strlen(sqffd_result_string(SQFFD_OK)) == 0) {
        fprintf(stderr, "consumer: lattice %d, %d iterations\n", opt.lattice[0], opt.max_iterations);
        return 1;
    }
    printf("consumer: sqffd %s ok\n", SQFFD_VERSION_STRING);
    return 0;
}
EOF

# ---- make install + pkg-config
D=$T/destdir
make --no-print-directory install DESTDIR="$D" PREFIX=/usr/local > "$T/install.log" 2>&1 \
    || fail "make install DESTDIR=$D PREFIX=/usr/local" "$T/install.log"
PC=$D/usr/local/lib/pkgconfig/sqffd.pc
cmp -s sqffd.h "$D/usr/local/include/sqffd.h" || fail "installed sqffd.h differs"
[ -x "$D/usr/local/bin/sqffd" ] || fail "sqffd not installed to bin"
[ -f "$PC" ] || fail "no $PC"
grep -qx 'prefix=/usr/local' "$PC" || fail "sqffd.pc: prefix is not /usr/local" "$PC"
grep -qx "Version: $version" "$PC" || fail "sqffd.pc: version is not $version" "$PC"

if command -v pkg-config >/dev/null 2>&1; then
    how=pkg-config
    flags=$(PKG_CONFIG_PATH= PKG_CONFIG_LIBDIR="$D/usr/local/lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$D" \
        pkg-config --cflags --libs sqffd) || fail "pkg-config --cflags --libs sqffd" "$PC"
    pcver=$(PKG_CONFIG_PATH= PKG_CONFIG_LIBDIR="$D/usr/local/lib/pkgconfig" pkg-config --modversion sqffd)
    [ "$pcver" = "$version" ] || fail "pkg-config --modversion sqffd: '$pcver', expected $version"
else
    how="sqffd.pc read by hand (pkg-config not installed)"
    prefix=$(sed -n 's/^prefix=//p' "$PC")
    includedir=$(sed -n 's/^includedir=//p' "$PC" | sed "s|\${prefix}|$prefix|")
    flags="$(sed -n 's/^Cflags: *//p' "$PC" | sed "s|\${includedir}|$D$includedir|") $(sed -n 's/^Libs: *//p' "$PC")"
fi
case "$flags" in *"-I$D/usr/local/include"*"-lm"*) ;; *) fail "flags from sqffd.pc: '$flags'" "$PC" ;; esac
# shellcheck disable=SC2086
$CC -std=c99 -Wall -Wextra -Werror -o "$T/consumer_pc" "$T/consumer/main.c" $flags > "$T/pc.log" 2>&1 \
    || fail "$CC main.c $flags" "$T/pc.log"
"$T/consumer_pc" > "$T/pc_run.log" 2>&1 || fail "consumer built with pkg-config flags" "$T/pc_run.log"

# ---- a prefix with a blank: make install quotes it; sqffd.pc escapes it, as pkg-config prints it (a shell that
# parses the flags, as make's recipes do, reads it back whole)
B="$T/blank dest"
make --no-print-directory install DESTDIR="$B" PREFIX="/opt/my tools" > "$T/install_blank.log" 2>&1 \
    || fail "make install PREFIX=\"/opt/my tools\"" "$T/install_blank.log"
cmp -s sqffd.h "$B/opt/my tools/include/sqffd.h" && [ -x "$B/opt/my tools/bin/sqffd" ] \
    || fail "make install PREFIX=\"/opt/my tools\": sqffd.h or sqffd not in place" "$T/install_blank.log"
BPC="$B/opt/my tools/lib/pkgconfig/sqffd.pc"
grep -qx 'prefix=/opt/my\\ tools' "$BPC" || fail "sqffd.pc: the prefix's blank is not escaped" "$BPC"
# the flags as a build with DESTDIR as its root sees them: ${includedir} is DESTDIR (blanks escaped) + the prefix's
grep -qx 'Cflags: -I${includedir}' "$BPC" && grep -qx 'includedir=${prefix}/include' "$BPC" || fail "sqffd.pc: Cflags" "$BPC"
bflags="-I$(printf '%s' "$B" | sed 's/ /\\ /g')$(sed -n 's/^prefix=//p' "$BPC")/include"
eval "$CC -std=c99 -Wall -Wextra -Werror -o \"\$T/consumer_blank\" \"\$T/consumer/main.c\" $bflags -lm" > "$T/blank.log" 2>&1 \
    || fail "$CC main.c $bflags (a prefix with a blank)" "$T/blank.log"

# ---- CMake: add_subdirectory, FetchContent, find_package after cmake --install
if ! command -v cmake >/dev/null 2>&1; then
    echo "package test: cmake not installed, CMake half skipped"
    echo "package: make install and $how: ok"
    exit 0
fi
cat > "$T/consumer/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.14)
project(sqffd_consumer C)
if(MODE STREQUAL "subdirectory")
  add_subdirectory("${SQFFD_SOURCE}" sqffd)
elseif(MODE STREQUAL "fetchcontent")
  # SOURCE_DIR needs no download: skip the no-op populate sub-build, most of the
  # time otherwise (CMake < 3.19 ignored SOURCE_DIR when disconnected)
  if(NOT CMAKE_VERSION VERSION_LESS 3.19)
    set(FETCHCONTENT_FULLY_DISCONNECTED ON)
  endif()
  include(FetchContent)
  FetchContent_Declare(sqffd SOURCE_DIR "${SQFFD_SOURCE}")
  FetchContent_MakeAvailable(sqffd)
else()
  find_package(sqffd "${SQFFD_VERSION}" EXACT REQUIRED NO_DEFAULT_PATH PATHS "${SQFFD_PREFIX}")
  get_target_property(inc sqffd::sqffd INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT inc STREQUAL "${SQFFD_PREFIX}/include")
    message(FATAL_ERROR "sqffd::sqffd includes ${inc}, not the installed ${SQFFD_PREFIX}/include")
  endif()
endif()
add_executable(consumer main.c)
target_link_libraries(consumer PRIVATE sqffd::sqffd)
EOF

cmake -G "Unix Makefiles" -S "$ROOT" -B "$T/sqffd_build" > "$T/install_cmake.log" 2>&1 \
    && cmake --install "$T/sqffd_build" --prefix "$T/prefix" >> "$T/install_cmake.log" 2>&1 \
    || fail "cmake configure + install of sqffd" "$T/install_cmake.log"
if grep -q 'CMake Warning' "$T/install_cmake.log"; then fail "CMake warnings configuring sqffd" "$T/install_cmake.log"; fi
# The three consumers are independent: configured, built and run side by side.
for mode in subdirectory fetchcontent find_package; do
    (cmake -G "Unix Makefiles" --no-warn-unused-cli -S "$T/consumer" -B "$T/build_$mode" -DMODE=$mode \
        -DSQFFD_SOURCE="$ROOT" -DSQFFD_PREFIX="$T/prefix" -DSQFFD_VERSION="$version" \
        && cmake --build "$T/build_$mode" && "$T/build_$mode/consumer" && echo "consumer status: ok") \
        > "$T/$mode.log" 2>&1 &
done
wait
for mode in subdirectory fetchcontent find_package; do
    grep -qx 'consumer status: ok' "$T/$mode.log" || fail "CMake consumer through $mode" "$T/$mode.log"
    if grep -q 'CMake Warning' "$T/$mode.log"; then fail "CMake warnings through $mode" "$T/$mode.log"; fi
done
echo "package: make install, $how and CMake (add_subdirectory, FetchContent, find_package): ok"
