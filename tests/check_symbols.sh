#!/bin/sh
# The core object may only reference libm, memcpy/memset/memmove and assert's
# failure hook, and may define no writable global data.
obj=$1
libm=$(ls /lib/*/libm.so.6 /usr/lib/*/libm.so.6 /lib64/libm.so.6 2>/dev/null | head -n 1)
[ -n "$libm" ] || { echo "check-symbols: libm.so.6 not found"; exit 1; }
allowed=$(nm -D --defined-only "$libm" | awk '{print $NF}' | sed 's/@.*//'; printf 'memcpy\nmemset\nmemmove\n__assert_fail\n')
bad=0
for s in $(nm -u "$obj" | awk '{print $NF}'); do
  echo "$allowed" | grep -qx "$s" || { echo "check-symbols: core references $s"; bad=1; }
done
globals=$(nm --defined-only "$obj" | awk '$2 ~ /^[DdBbCcGgSs]$/ {print $3}')
[ -z "$globals" ] || { echo "check-symbols: core defines writable data: $globals"; bad=1; }
[ $bad -eq 0 ] && echo "symbols: core uses libm and memcpy/memset/memmove only, no writable globals"
exit $bad
