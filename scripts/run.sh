#!/usr/bin/env bash
# run.sh: install what is missing, build, and run the main job on the bundled default scene.
# For now the main job is the G-buffer of data/dragon_plane.glb at 1920x1080, written to
# out/dragon_plane.{exr,json} and out/dragon_plane_{normal,depth}.png.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/setup.sh"
"$here/scripts/build.sh" "$here/build"
"$here/build/obscura" gbuffer "$here/build/data/dragon_plane.glb" -o "$here/out/dragon_plane" "$@"
