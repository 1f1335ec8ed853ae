#!/usr/bin/env bash
# The runtime in a browser: builds the C ABI (facebake-ffi, no_std) for wasm32-unknown-unknown,
# installs the viewer's npm packages (three, playwright-core) and, where missing, Debian's
# Chromium, then runs web/test/browser-test.mjs: headless Chromium opens the viewer, which
# plays every golden rig and the capture through the wasm module; every hash line (positions
# and normals) must equal fixtures/golden/hashes.txt, hashes_planar.txt and hashes_normals.txt,
# the viewer's TRC input must equal the golden actor frames, and screenshots of the drawn face
# (out/browser/) must be neither blank nor identical at rest and with the mouth open.
set -euo pipefail
export LC_ALL=C
cd "$(dirname "$0")/.."

tdir=${CARGO_TARGET_DIR:-$PWD/target}
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 || true
# Without the release profile's debug info: the module the page loads is then about 110 KB.
CARGO_PROFILE_RELEASE_DEBUG=0 cargo build -p facebake-ffi --release --no-default-features \
  --target wasm32-unknown-unknown
cargo clippy -p facebake-ffi --no-default-features --target wasm32-unknown-unknown -- -D warnings
mkdir -p web/build
cp "$tdir/wasm32-unknown-unknown/release/facebake_ffi.wasm" web/build/
echo "browser: web/build/facebake_ffi.wasm, $(wc -c < web/build/facebake_ffi.wasm) bytes"
# The module exports exactly the functions the header declares, and imports nothing.
declared=$(grep -oE '\bfb_[a-z0-9_]+\(' ffi/include/facebake.h | tr -d '(' | sort -u)
exported=$(node -e '
  const m = new WebAssembly.Module(require("fs").readFileSync("web/build/facebake_ffi.wasm"));
  if (WebAssembly.Module.imports(m).length) { console.error("browser: the module has imports"); process.exit(1); }
  for (const e of WebAssembly.Module.exports(m)) if (e.kind === "function" && e.name.startsWith("fb_")) console.log(e.name);
' | sort -u)
if [ "$declared" != "$exported" ]; then
  diff <(echo "$declared") <(echo "$exported") >&2 || true
  echo "browser: the wasm module does not export exactly the functions facebake.h declares" >&2
  exit 1
fi
echo "browser: $(echo "$exported" | wc -l) functions exported, as facebake.h declares; no imports"

CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$CHROMIUM" ] && command -v apt-get >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
export CHROMIUM
if ! command -v npm >/dev/null && command -v apt-get >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
fi
(cd web && npm ci --no-audit --no-fund)
node web/test/browser-test.mjs 2>&1 | grep -v 'GL Driver Message'
