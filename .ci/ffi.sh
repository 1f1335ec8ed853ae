#!/usr/bin/env bash
# The C ABI from C and C++: builds facebake-ffi (release), compiles ffi/examples/c and
# ffi/examples/cpp with the system compilers against the checked-in header and the static
# library (the C one against the shared library too), plays every golden rig and take through
# them, and compares their per-frame hashes with fixtures/golden/hashes.txt and
# hashes_planar.txt, and the C example's normals with hashes_normals.txt and its packed take
# with hashes_take.txt (exact match of every frame and sequence line; the files are read at run
# time, so a re-bless of the goldens needs no change here). Also compiles the README's C
# example, and builds the no_std static library for thumbv7em-none-eabihf (firmware in C).
# Exits non-zero on any difference.
set -euo pipefail
export LC_ALL=C
cd "$(dirname "$0")/.."

CC=${CC:-cc}
CXX=${CXX:-c++}
# A fresh machine may lack the system compilers: install Debian's.
if ! command -v "$CC" >/dev/null || ! command -v "$CXX" >/dev/null || ! command -v nm >/dev/null; then
  apt-get update -qq && apt-get install -y -qq gcc g++ binutils >/dev/null
fi
# Cargo's output folder: the one CARGO_TARGET_DIR names, if set, else target/.
tdir=${CARGO_TARGET_DIR:-$PWD/target}
out=$tdir/ffi-examples
mkdir -p "$out"

cargo build -p facebake-ffi --release
lib=$tdir/release/libfacebake_ffi.a
# What the static library needs from the system on Linux (std's threads, dynamic loading, libm).
libs=(-lpthread -ldl -lm)

"$CC" -std=c11 -O2 -Wall -Wextra -Wpedantic -Werror -I ffi/include \
  ffi/examples/c/play_golden.c "$lib" "${libs[@]}" -o "$out/play_golden_c"
# The same C program against the shared library, to show the dynamic build works too.
"$CC" -std=c11 -O2 -Wall -Wextra -Wpedantic -Werror -I ffi/include \
  ffi/examples/c/play_golden.c -L "$tdir/release" -lfacebake_ffi -Wl,-rpath,"$tdir/release" \
  -o "$out/play_golden_c_shared"
"$CXX" -std=c++17 -O2 -Wall -Wextra -Wpedantic -Werror -I ffi/include \
  ffi/examples/cpp/play_golden.cpp "$lib" "${libs[@]}" -o "$out/play_golden_cpp"

# The README's C example compiles as printed (with a main added).
awk '/^## From C/ {c = 1} c && /^```c$/ {p = 1; next} p && /^```$/ {exit} p' ffi/README.md \
  > "$out/readme.c"
printf 'int main(void) { return 0; }\n' >> "$out/readme.c"
"$CC" -std=c11 -Wall -Wextra -Wpedantic -Werror -I ffi/include "$out/readme.c" "$lib" \
  "${libs[@]}" -o "$out/readme_c"

# Firmware: the no_std build for a Cortex-M4F. Both static libraries define every function the
# header declares.
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
cargo build -p facebake-ffi --release --no-default-features --target thumbv7em-none-eabihf
declared=$(grep -oE '\bfb_[a-z0-9_]+\(' ffi/include/facebake.h | tr -d '(' | sort -u)
for archive in "$lib" "$tdir/thumbv7em-none-eabihf/release/libfacebake_ffi.a"; do
  defined=$(nm -g --defined-only "$archive" 2>/dev/null | awk '$2 == "T" && $3 ~ /^fb_/ {print $3}' | sort -u)
  if [ "$declared" != "$defined" ]; then
    diff <(echo "$declared") <(echo "$defined") >&2 || true
    echo "ffi: $archive does not define exactly the functions facebake.h declares" >&2
    exit 1
  fi
done
echo "ffi: $(echo "$declared" | wc -l) functions declared, defined by the host and thumbv7em static libraries"

# The golden lines the examples must reproduce, in file order.
pattern='^(coefficients|weights|coefficients_k4|product|planar|capture) (frame [0-9]+|sequence) [0-9a-f]{16}$'
cat fixtures/golden/hashes.txt fixtures/golden/hashes_planar.txt | grep -E "$pattern" \
  | sort -s -k1,1 > "$out/expected.txt"
# The C example also prints every frame's normals (fb_normals) behind the word "normals", and
# plays the packed take (fb_take_next_frame) as hashes_take.txt records it.
{ cat "$out/expected.txt"; grep -E "$pattern" fixtures/golden/hashes_normals.txt | sed 's/^/normals /'
  grep -E '^take (frame [0-9]+|sequence) [0-9a-f]{16}$' fixtures/golden/hashes_take.txt; } \
  | sort -s -k1,1 > "$out/expected_c.txt"

status=0
for lang in c c_shared cpp; do
  "$out/play_golden_$lang" fixtures/golden > "$out/$lang.txt" 2> "$out/$lang.log" || {
    cat "$out/$lang.log" >&2
    echo "ffi: the $lang example failed" >&2
    status=1
    continue
  }
  sort -s -k1,1 "$out/$lang.txt" > "$out/$lang.sorted.txt"
  want="$out/expected.txt"
  case $lang in c | c_shared) want="$out/expected_c.txt" ;; esac
  if diff -u "$want" "$out/$lang.sorted.txt" > "$out/$lang.diff"; then
    echo "ffi: $lang example: $(wc -l < "$out/$lang.txt") hash lines, all equal to the golden files ($(wc -l < "$want") expected)"
  else
    head -40 "$out/$lang.diff" >&2
    echo "ffi: the $lang example's hashes differ from the golden files (full diff: $out/$lang.diff)" >&2
    status=1
  fi
done
exit "$status"
