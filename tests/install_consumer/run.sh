#!/usr/bin/env bash
# install_exports_a_usable_cmake_package: install the build tree into a temporary prefix, then
# configure, build and run a consumer project against it with find_package(obscura).
set -euo pipefail
build="$1"; src="$(cd "$(dirname "$0")" && pwd)"
work="$build/test-tmp/install_consumer"
rm -rf "$work"; mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >/dev/null
# The consumer uses the build's C compiler; a sanitized build (OBS_SANITIZE=ON) also needs the
# sanitizer runtimes on the consumer's link line.
cache="$build/CMakeCache.txt"
cc="$(sed -n 's/^CMAKE_C_COMPILER:[A-Z]*=//p' "$cache")"
extra=()
[ -n "$cc" ] && extra+=("-DCMAKE_C_COMPILER=$cc")
if grep -q '^OBS_SANITIZE:BOOL=ON' "$cache"; then
  extra+=("-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
fi
cmake -S "$src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release "${extra[@]}" >/dev/null
cmake --build "$work/build" >/dev/null
"$work/build/consumer"
