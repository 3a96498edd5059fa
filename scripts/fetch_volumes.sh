#!/bin/sh
# fetch_volumes.sh: the real volume datasets (docs/volume.md, "Datasets"), extracted from Debian 12
# packages WITHOUT installing them (apt-get download + dpkg -x, as setup.sh does for the meshes):
#   data/cache/volumes/ch2better.nii.gz  mricron-data 1.2.20211006+dfsg-4: /usr/share/mricron/templates/
#                                        ch2better.nii.gz, NIfTI-1 gz, 301x370x316 uint8, 0.5 mm
#   data/cache/volumes/cranium.nrrd      invesalius-examples 3.1.99998-4: Cranium.inv3 (a gzip tar) ->
#                                        matrix.dat (int16 LE, stored z,y,x C order = x fastest,
#                                        256x256x108), wrapped in an attached raw NRRD header with
#                                        the project's spacing 0.9570312 x 0.9570312 x 1.5 mm
# Checked against data/volumes.sha256. Idempotent: does nothing when both files are present.
# Needs apt-get, dpkg, tar, gzip, sha256sum (no root: apt-get download works as any user).
set -eu
here="$(cd "$(dirname "$0")/.." && pwd)"
dest="$here/data/cache/volumes"
mkdir -p "$dest"

if [ ! -f "$dest/ch2better.nii.gz" ] || [ ! -f "$dest/cranium.nrrd" ]; then
  tmp="$(mktemp -d)"; chmod 755 "$tmp"
  trap 'rm -rf "$tmp"' EXIT
  # Installed copies are used when present; otherwise the .debs are downloaded and unpacked in tmp.
  ch2=/usr/share/mricron/templates/ch2better.nii.gz
  inv=/usr/share/doc/invesalius-examples/examples/Cranium.inv3
  if [ ! -f "$ch2" ]; then
    (cd "$tmp" && apt-get download mricron-data >/dev/null 2>&1 && dpkg -x mricron-data_*.deb x) || {
      echo "fetch_volumes: cannot download or unpack mricron-data (apt sources? network?)" >&2; exit 1; }
    ch2="$tmp/x/usr/share/mricron/templates/ch2better.nii.gz"
  fi
  if [ ! -f "$inv" ]; then
    (cd "$tmp" && apt-get download invesalius-examples >/dev/null 2>&1 && dpkg -x invesalius-examples_*.deb x) || {
      echo "fetch_volumes: cannot download or unpack invesalius-examples (apt sources? network?)" >&2; exit 1; }
    inv="$tmp/x/usr/share/doc/invesalius-examples/examples/Cranium.inv3"
  fi
  cp "$ch2" "$dest/ch2better.nii.gz"

  # Cranium.inv3: a gzip tar holding one directory with main.plist and matrix.dat.
  mkdir -p "$tmp/inv3"
  tar -xzf "$inv" -C "$tmp/inv3" --wildcards '*/main.plist' '*/matrix.dat'
  plist="$(find "$tmp/inv3" -name main.plist | head -n 1)"
  matrix="$(find "$tmp/inv3" -name matrix.dat | head -n 1)"
  # The plist must still say what the header below assumes: int16, shape (z, y, x) = (108, 256, 256).
  tr -d ' \t\r\n' < "$plist" | grep -q '<key>dtype</key><string>int16</string>' || {
    echo "fetch_volumes: $inv: matrix dtype is not int16" >&2; exit 1; }
  tr -d ' \t\r\n' < "$plist" | grep -q '<key>shape</key><array><integer>108</integer><integer>256</integer><integer>256</integer></array>' || {
    echo "fetch_volumes: $inv: matrix shape is not 108x256x256" >&2; exit 1; }
  [ "$(wc -c < "$matrix")" -eq 14155776 ] || { echo "fetch_volumes: $matrix: not 256*256*108*2 bytes" >&2; exit 1; }
  {
    printf 'NRRD0004\n'
    printf '# Cranium.inv3 from Debian invesalius-examples 3.1.99998-4 (InVesalius, GPL-2): "ProMED CT 0051", CT, HU\n'
    printf '# made by obscura scripts/fetch_volumes.sh from matrix.dat (numpy int16, shape z,y,x = 108,256,256)\n'
    printf 'type: short\ndimension: 3\nsizes: 256 256 108\nspacings: 0.9570312 0.9570312 1.5\n'
    printf 'endian: little\nencoding: raw\n\n'
    cat "$matrix"
  } > "$dest/cranium.nrrd.tmp"
  mv "$dest/cranium.nrrd.tmp" "$dest/cranium.nrrd"
  echo "fetch_volumes: volumes extracted to $dest"
fi

if ! (cd "$dest" && sha256sum --quiet --check "$here/data/volumes.sha256" >/dev/null 2>&1); then
  echo "fetch_volumes: warning: data/cache/volumes differ from data/volumes.sha256 (Debian 12's mricron-data" \
       "1.2.20211006+dfsg-4 and invesalius-examples 3.1.99998-4):" >&2
  (cd "$dest" && sha256sum --check "$here/data/volumes.sha256" 2>&1 | grep -v ': OK$' >&2) || true
fi
