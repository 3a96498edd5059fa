#!/usr/bin/env bash
# setup.sh: install exactly the Debian 12 packages obscura needs, skipping what is present.
# Usage: scripts/setup.sh [--dev]   (--dev adds the sanitizer/fuzzer/profiling tools)
# Runs apt-get as root (uses sudo when not root). Idempotent.
set -euo pipefail

PKGS=(
  build-essential cmake pkg-config
  libembree-dev            # Embree 3: ground truth ray tracing (build-notes.md)
  libopenimageio-dev openimageio-tools python3-imath  # EXR/PNG I/O; python3-imath silences Imath's CMake warning
  libtinygltf-dev          # glTF 2.0 loader (compiled library in Debian)
  libdraco-dev libmeshoptimizer-dev  # KHR_draco_mesh_compression and EXT_meshopt_compression decoders (glTF)
  nlohmann-json3-dev       # JSON parser for the glTF check before tinygltf (the one tinygltf is built with)
  libcjson-dev             # cJSON: the C library's JSON reader (SSS material schema, scene settings, presets)
  libnifti2-dev libteem-dev  # volumes: NIfTI-1/2 (nifticlib) and NRRD (teem)
  libopenmpi-dev openmpi-bin  # MPI (optional at build time, OBS_WITH_MPI): mpirun -np N obscura truth ao (docs/scale.md)
  clang-14 libclang-rt-14-dev  # ASan/UBSan/libFuzzer (tests)
  # Headless GL on Mesa's llvmpipe: the GLSL ports' match tests (tests/gl, must run in CI), the
  # benchmark's GLSL side (bench/gl_bench.c) and the llvmpipe peer (../shared/tools/llvmpipe-peer)
  libegl-dev libopengl-dev libgl-dev zlib1g-dev libegl-mesa0 libgl1-mesa-dri
)
if [ "${1:-}" = "--dev" ]; then
  PKGS+=(valgrind linux-perf hyperfine gnuplot-nox)
fi

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all packages present"
fi

# Meshes: the Stanford bunny, the Chinese dragon and the armadillo ship in libcgal-demo's data tarball.
# We extract only those OFF files into data/cache (ignored by git); the build's obscura_mkdata (target
# obscura_data) converts them. data/README.md says where each comes from and under which terms.
here="$(cd "$(dirname "$0")/.." && pwd)"
cache="$here/data/cache"
if [ ! -f "$cache/bunny00.off" ] || [ ! -f "$cache/ChineseDragon-10kv.off" ] || [ ! -f "$cache/armadillo.off" ]; then
  mkdir -p "$cache"
  tmp="$(mktemp -d)"; chmod 755 "$tmp"
  tarball=/usr/share/doc/libcgal-dev/data.tar.gz
  if [ ! -f "$tarball" ]; then
    (cd "$tmp" && apt-get download libcgal-demo >/dev/null && dpkg -x libcgal-demo_*.deb x)
    tarball="$tmp/x/usr/share/doc/libcgal-dev/data.tar.gz"
  fi
  tar -xzf "$tarball" -C "$tmp" data/meshes/bunny00.off data/meshes/ChineseDragon-10kv.off data/meshes/armadillo.off
  cp "$tmp"/data/meshes/*.off "$cache/"
  rm -rf "$tmp"
  echo "setup: meshes extracted to $cache"
fi
# The bytes the committed figures were made from: Debian 12's libcgal-demo 5.5.1-2 (data/meshes.sha256).
# Another CGAL release may ship other files; the scenes still build from them, but they differ.
if ! (cd "$cache" && sha256sum --quiet --check "$here/data/meshes.sha256" >/dev/null 2>&1); then
  echo "setup: warning: data/cache/*.off differ from data/meshes.sha256 (Debian 12's libcgal-demo 5.5.1-2):" >&2
  (cd "$cache" && sha256sum --check "$here/data/meshes.sha256" 2>&1 | grep -v ': OK$' >&2) || true
fi
# The real volumes (docs/volume.md, "Datasets"): the InVesalius head CT and the Colin27 MRI, from
# Debian packages that are downloaded and unpacked, not installed. A failure is a warning: the tests
# that need them say that they are absent.
sh "$here/scripts/fetch_volumes.sh" || echo "setup: warning: volume datasets not fetched (tests will say so)" >&2
