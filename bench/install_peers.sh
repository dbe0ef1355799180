#!/bin/sh
# Installs the benchmark peers (nanoflann, LAPACKE, zlib, scikit-image) when they are missing.
# Never fails: without root or network the peer columns are skipped.
need=""
[ -f /usr/include/nanoflann.hpp ] || need="$need libnanoflann-dev"
[ -f /usr/include/lapacke.h ] || need="$need liblapacke-dev"
[ -f /usr/include/zlib.h ] || need="$need zlib1g-dev"
{ /usr/bin/python3 -c "import skimage" || python3 -c "import skimage"; } 2>/dev/null || need="$need python3-skimage"
# a real 181 x 217 x 181 brain for bench_volume's end-to-end row (the ICBM/Colin "ch2" template of
# Debian's mricron-data, unpacked into build/peers; apt-get download needs no root)
brain=build/peers/mricron/usr/share/mricron/templates/ch2.nii.gz
if [ ! -f "$brain" ] && command -v apt-get >/dev/null 2>&1; then
  mkdir -p build/peers && (cd build/peers && apt-get download mricron-data >/dev/null 2>&1 &&
    dpkg -x mricron-data_*.deb mricron && rm -f mricron-data_*.deb) ||
    echo "bench: could not fetch mricron-data (no network?); the brain row is skipped"
fi
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
