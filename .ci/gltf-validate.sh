#!/usr/bin/env bash
# Validates every .glb the demo writes with the Khronos glTF validator (npm `gltf-validator`):
# zero errors and zero warnings, or the step fails. The validator is installed once into a cache
# folder (FACEBAKE_NPM_CACHE, default ~/.cache/facebake/gltf-validator). The demo's outputs are
# taken from DEMO_OUT if it names a folder with .glb files, else the demo is run (release build,
# one timing repetition) into target/gltf-validate/.
set -euo pipefail
cd "$(dirname "$0")/.."

cache="${FACEBAKE_NPM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/facebake/gltf-validator}"
if [ ! -f "$cache/node_modules/gltf-validator/package.json" ]; then
  mkdir -p "$cache"
  npm install --prefix "$cache" --no-audit --no-fund gltf-validator
fi

out="${DEMO_OUT:-}"
if [ -z "$out" ] || ! ls "$out"/*.glb >/dev/null 2>&1; then
  out=target/gltf-validate
  cargo run --release -q -p facebake -- demo --out "$out" --repetitions 1 >/dev/null
fi

shopt -s nullglob
files=("$out"/*.glb)
if [ ${#files[@]} -eq 0 ]; then
  echo "no .glb files in $out"
  exit 1
fi
node .ci/gltf-validate.cjs "$cache" "${files[@]}"
