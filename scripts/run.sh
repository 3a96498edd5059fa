#!/usr/bin/env bash
# run.sh: install what is missing, build, and run the main job: `obscura render` on the bundled
# default scene, build/data/cornell_hybrid.glb (a Cornell box with an opaque block that shows
# ambient occlusion, a translucent marble bunny, a small volume and a point light; its render
# settings are in the scene's glTF extras, docs/render.md). It writes out/cornell_hybrid.png (the
# beauty image), out/cornell_hybrid.exr (every layer: beauty, direct, ambient, ao, sss, volume,
# depth, normal, albedo) and out/cornell_hybrid.json (settings, camera, pass log), and prints
# where they are with the pass log: which passes ran, how long each took, and why each is there.
# Extra arguments go to `obscura render` (e.g. --size 960x540, --reference, --dry-run).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/setup.sh"
"$here/scripts/build.sh" "$here/build"
"$here/build/obscura" render "$here/build/data/cornell_hybrid.glb" -o "$here/out" "$@"
