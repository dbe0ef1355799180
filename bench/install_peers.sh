#!/bin/sh
# Installs the benchmark peers (nanoflann, LAPACKE, zlib, scikit-image) when they are missing.
# Never fails: without root or network the peer columns are skipped.
need=""
[ -f /usr/include/nanoflann.hpp ] || need="$need libnanoflann-dev"
[ -f /usr/include/lapacke.h ] || need="$need liblapacke-dev"
[ -f /usr/include/zlib.h ] || need="$need zlib1g-dev"
{ /usr/bin/python3 -c "import skimage" || python3 -c "import skimage"; } 2>/dev/null || need="$need python3-skimage"
[ -z "$need" ] && exit 0
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "bench: peers not installed ($need): not root or no apt-get; peer columns skipped"
  exit 0
fi
echo "bench: installing peers:$need"
if apt-get update -qq >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $need >/dev/null 2>&1; then
  echo "bench: peers installed"
else
  echo "bench: could not install$need (no network?); peer columns skipped"
fi
exit 0
