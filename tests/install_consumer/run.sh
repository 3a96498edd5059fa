#!/usr/bin/env bash
# install_exports_a_usable_cmake_package: install the build tree into a temporary prefix, then
# configure, build and run a consumer project against it with find_package(obscura).
set -euo pipefail
build="$1"; src="$(cd "$(dirname "$0")" && pwd)"
work="$build/test-tmp/install_consumer"
rm -rf "$work"; mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >/dev/null
cmake -S "$src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/build" >/dev/null
"$work/build/consumer"
