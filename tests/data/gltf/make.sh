#!/usr/bin/env bash
# make.sh: regenerate the compressed and quantized test scenes in this directory from source.glb
# with the ecosystem's own tools (README.md). Needs node/npm; installs the pinned tools into a
# temporary directory. The committed files were made with exactly these commands.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
python3 "$here/make_source.py" "$here/source.glb"
(cd "$tmp" && npm install --no-audit --no-fund --silent gltfpack@1.3.0 gltf-pipeline@4.3.1 >/dev/null)
B="$tmp/node_modules/.bin"
S="$here/source.glb"
"$B/gltfpack" -i "$S" -o "$here/quantized.glb"                 # KHR_mesh_quantization (gltfpack's default)
"$B/gltfpack" -i "$S" -o "$here/meshopt.glb" -c                # + EXT_meshopt_compression
"$B/gltfpack" -i "$S" -o "$here/meshopt_filters.glb" -cc       # + meshopt filters (OCTAHEDRAL normals)
"$B/gltfpack" -i "$S" -o "$here/meshopt_float.glb" -c -noq     # EXT_meshopt_compression on float data
"$B/gltf-pipeline" -i "$S" -o "$here/draco.glb" -d             # KHR_draco_mesh_compression
"$B/gltf-pipeline" -i "$S" -o "$here/draco_embedded.gltf" -d   # the same as .gltf with a data: URI
"$B/gltf-pipeline" -i "$S" -o "$here/separate.gltf" -s         # plain .gltf + separate.bin
