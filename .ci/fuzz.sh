#!/usr/bin/env bash
# Fuzzing for facebake (issue 14): every cargo-fuzz target in fuzz/ runs for a bounded time from
# a seed corpus built from fixtures/ and fixtures/repro/ (the issue's regression inputs), then
# the whole corpus is replayed once. Prints the executions per target.
#
# Needs the nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`).
# FUZZ_SECONDS (default 20) bounds each target's run; FUZZ_RSS_MB (default 2048) is the memory
# a single input may use before libFuzzer calls it a crash (the readers' allocation bounds).
set -euo pipefail
cd "$(dirname "$0")/.."

secs=${FUZZ_SECONDS:-20}
rss=${FUZZ_RSS_MB:-2048}
corpus=fuzz/corpus
targets=(gltf capture layout mask_png blob take)

# seed TARGET PREFIX FILE...: copies each FILE into TARGET's corpus, after the bytes PREFIX
# (a printf format) that the target reads as its selector.
seed() {
  local target=$1 prefix=$2
  shift 2
  mkdir -p "$corpus/$target"
  for f in "$@"; do
    [ -f "$f" ] || continue
    { printf "$prefix"; cat "$f"; } > "$corpus/$target/seed-$(basename "$f")"
  done
}

seed gltf '' fixtures/*.glb fixtures/repro/*.gltf fixtures/repro/*.glb
seed capture '\000' fixtures/c3d/*.c3d
seed capture '\001' fixtures/JawMoCap.trc fixtures/repro/capture_subnormal_rate_roundtrip.trc
mkdir -p "$corpus/capture"
printf '\002# rate=60\n# units=cm\nframe,time,A_x,A_y,A_z,B_x,B_y,B_z\n1,0,1,2,3,4,5,6\n2,0.0167,1,2,,4,5,NaN\n' \
  > "$corpus/capture/seed-small.csv"
seed layout '\000' fixtures/facecap_jawmocap_layout.toml
seed layout '\001' fixtures/repro/layout_json_float_1ulp.json
seed mask_png '' fixtures/repro/*.png
seed blob '\000\000\000\000\000\000\000\000' fixtures/golden/*.fbk fixtures/repro/*.fbk
seed take '\000\000' fixtures/golden/*.fbt
# The payload alone (after the 20-byte header), which the target seals afresh.
mkdir -p "$corpus/take"
for f in fixtures/golden/*.fbt; do
  { printf '\001\007'; tail -c +21 "$f"; } > "$corpus/take/seed-payload-$(basename "$f")"
done

cd fuzz
for t in "${targets[@]}"; do
  log=$(mktemp)
  cargo +nightly fuzz run "$t" "corpus/$t" -- \
    -max_total_time="$secs" -rss_limit_mb="$rss" -max_len=1048576 -print_final_stats=1 \
    >"$log" 2>&1 || { tail -40 "$log"; echo "fuzz target $t failed"; exit 1; }
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  echo "fuzz $t: ${runs:-?} executions in ${secs} s"
  # Replay the whole corpus (seeds, regression inputs and what the run found) once.
  cargo +nightly fuzz run "$t" "corpus/$t" -- -runs=0 -rss_limit_mb="$rss" >"$log" 2>&1 \
    || { tail -40 "$log"; echo "corpus replay of $t failed"; exit 1; }
  echo "fuzz $t: corpus of $(ls "corpus/$t" | wc -l) inputs replayed"
  rm -f "$log"
done
