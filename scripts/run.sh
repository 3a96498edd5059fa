#!/usr/bin/env bash
# run.sh: install what is missing, build, and run the main job on the bundled default scene:
# the G-buffer of data/dragon_plane.glb at 1920x1080 (out/dragon_plane.{exr,json},
# out/dragon_plane_{normal,depth}.png), then every AO technique on it with its paper defaults and
# a 64-pixel guard band (out/ao/<method>.{exr,png,json} and out/ao/<method>_blend.png).
# Extra arguments go to the G-buffer command.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/setup.sh"
"$here/scripts/build.sh" "$here/build"
obscura="$here/build/obscura"
scene="$here/build/data/dragon_plane.glb"
"$obscura" gbuffer "$scene" -o "$here/out/dragon_plane" "$@"
for m in $("$obscura" ao --list | awk '/^[a-z]/ {print $1}'); do
  "$obscura" ao --method "$m" --scene "$scene" --guard 64 -o "$here/out/ao/$m"
done
