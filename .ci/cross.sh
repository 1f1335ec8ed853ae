#!/usr/bin/env bash
# Proves the runtime's promises (issue #6):
#   * bit-identical output on every architecture: the golden hashes on x86_64, and cross-built
#     under qemu-user on aarch64, 32-bit big-endian PowerPC, i686 and 32-bit ARMv7 in Thumb mode
#     (thumbv7neon: the linear deformer's SMLAD kernels, the Cortex-M4's, run there with the
#     runtime's unit tests, which hold them to an exact reference on random rigs);
#   * runs on a Cortex-M4: the firmware plays every golden frame under QEMU mps2-an386 and must
#     print exactly the golden hashes, of the positions and of their normals (a panic exits
#     non-zero and fails), the packed JawMoCap take decoded from flash included; decoding a frame
#     costs at most 5% of the FaceCap K = 8 deformation it feeds, and the budget frame (10,000
#     vertices at K = 8 with the capture stages) fits 25 % of a 60 fps frame at 168 MHz (cycles
#     estimated from the Cortex-M4 TRM);
#   * never allocates: the firmware links no allocator (an alloc canary must fail to build) and
#     a host test counts allocations;
#   * no float on the per-frame path: load + deform built for thumbv6m (no FPU) links no
#     soft-float routine;
#   * bounded, data-independent cost: instructions per frame under callgrind (host) and a QEMU
#     plugin (Cortex-M4) are the same for every frame, rest pose and saturated poses included;
#     Rig::normals' (host) the same for every pose within ±2 rig units and bounded beyond.
#
# Installs what it needs, idempotently: rustup targets and llvm-tools, Debian's cross compilers,
# qemu-user and valgrind, and qemu-system-arm unpacked into a private directory (installing it
# with apt would remove qemu-utils). Prints PASS/FAIL lines and the figures; exits non-zero on
# any failure.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD
START=$SECONDS
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
FW_TARGET_DIR="$CARGO_TARGET_DIR/firmware"
TOOLS="${FACEBAKE_CI_TOOLS:-${XDG_CACHE_HOME:-$HOME/.cache}/facebake-ci}"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; fi

PASSED=0
FAILED=0
pass() { PASSED=$((PASSED + 1)); echo "PASS: $*"; }
fail() { FAILED=$((FAILED + 1)); echo "FAIL: $*"; }
figure() { echo "FIGURE: $*"; }
section() { echo; echo "== $* ($((SECONDS - START)) s)"; }

CROSS_TARGETS=(aarch64-unknown-linux-gnu powerpc-unknown-linux-gnu i686-unknown-linux-gnu
    thumbv7neon-unknown-linux-gnueabihf)
M4_TARGET=thumbv7em-none-eabihf
NOFPU_TARGET=thumbv6m-none-eabi
RIGS=(coefficients weights coefficients_k4 product)
declare -A M4_INSNS HOST_IR

# ---------------------------------------------------------------------------------------------
section "toolchain and packages"

installed_targets=$(rustup target list --installed)
for t in "${CROSS_TARGETS[@]}" "$M4_TARGET" "$NOFPU_TARGET"; do
    grep -qx "$t" <<<"$installed_targets" || rustup target add "$t"
done
HOST=$(rustc -vV | awk '/^host:/ {print $2}')
LLVM_BIN="$(rustc --print sysroot)/lib/rustlib/$HOST/bin"
[ -x "$LLVM_BIN/llvm-size" ] || rustup component add llvm-tools
for tool in llvm-size llvm-nm llvm-objdump; do
    [ -x "$LLVM_BIN/$tool" ] || { echo "FAIL: $tool missing from $LLVM_BIN"; exit 1; }
done

APT_PACKAGES=(qemu-user valgrind gcc
    gcc-aarch64-linux-gnu libc6-dev-arm64-cross
    gcc-powerpc-linux-gnu libc6-dev-powerpc-cross
    gcc-i686-linux-gnu libc6-dev-i386-cross
    gcc-arm-linux-gnueabihf libc6-dev-armhf-cross)
APT_UPDATED=0
apt_install() {
    local missing=()
    for p in "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
            missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "$APT_UPDATED" -eq 0 ]; then
        $SUDO apt-get update -qq
        APT_UPDATED=1
    fi
    echo "installing: ${missing[*]}"
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        "${missing[@]}" >/dev/null
}
apt_install "${APT_PACKAGES[@]}"

# qemu-system-arm, unpacked privately, with only its shared-library dependencies installed.
QEMU_ROOT="$TOOLS/qemu-system-arm"
QEMU_SYSTEM_ARM="$QEMU_ROOT/usr/bin/qemu-system-arm"
if [ ! -x "$QEMU_SYSTEM_ARM" ]; then
    if [ "$APT_UPDATED" -eq 0 ]; then
        $SUDO apt-get update -qq
        APT_UPDATED=1
    fi
    mkdir -p "$QEMU_ROOT"
    (cd "$WORK" && apt-get download -qq qemu-system-arm 2>/dev/null)
    dpkg -x "$WORK"/qemu-system-arm_*.deb "$QEMU_ROOT"
fi
mapfile -t QEMU_LIBS < <(apt-cache depends --important qemu-system-arm 2>/dev/null |
    awk '$1 == "Depends:" && $2 !~ /^[<]/ && $2 !~ /^qemu-/ {print $2}' | sort -u)
apt_install "${QEMU_LIBS[@]}"
if ldd "$QEMU_SYSTEM_ARM" | grep "not found" >/dev/null; then
    ldd "$QEMU_SYSTEM_ARM" | grep "not found"
    fail "qemu-system-arm is missing shared libraries"
    exit 1
fi
"$QEMU_SYSTEM_ARM" -machine help | grep '^mps2-an386 ' >/dev/null ||
    { echo "FAIL: this qemu-system-arm has no mps2-an386"; exit 1; }
echo "qemu-system-arm: $("$QEMU_SYSTEM_ARM" --version | head -n 1) ($QEMU_SYSTEM_ARM)"

# The instruction-count plugin (Debian ships plugin support but no plugins or headers).
PLUGIN="$TOOLS/frame_insns.so"
if [ ! -f "$PLUGIN" ] || [ "$ROOT/firmware/qemu/frame_insns.c" -nt "$PLUGIN" ]; then
    cc -O2 -Wall -Wextra -Werror -shared -fPIC -fvisibility=hidden \
        -o "$PLUGIN" "$ROOT/firmware/qemu/frame_insns.c"
fi

# ---------------------------------------------------------------------------------------------
section "golden data is what the baker makes; the runtime never allocates (host)"

if cargo test -q -p facebake-tests --test golden --test no_alloc >"$WORK/host.log" 2>&1; then
    pass "golden files equal a fresh bake byte for byte; bake is deterministic; no allocation in load + deform"
else
    cat "$WORK/host.log"
    fail "golden/no_alloc host tests"
fi

# ---------------------------------------------------------------------------------------------
section "bit-identical on every architecture"

# Runs the runtime's tests (unit tests with the fixed-point golden vectors, and the golden hash
# test) for target $1 and checks the golden test really ran.
runtime_tests() {
    local target=$1 log="$WORK/runtime-$1.log"
    local args=(-p facebake-runtime)
    [ "$target" = "$HOST" ] || args+=(--target "$target")
    if cargo test "${args[@]}" >"$log" 2>&1 &&
        grep -q "k4_coefficients_rig_is_bit_identical_to_the_golden_hashes ... ok" "$log" &&
        grep -q "product_rig_is_bit_identical_to_the_golden_hashes ... ok" "$log" &&
        grep -q "every_implementation_matches_the_exact_formula ... ok" "$log" &&
        grep -q "round_shift_golden ... ok" "$log"; then
        pass "$target: every golden frame hash and fixed-point golden vector matches"
    else
        tail -n 40 "$log"
        fail "$target: runtime golden tests"
    fi
}

export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L /usr/aarch64-linux-gnu"
export CARGO_TARGET_POWERPC_UNKNOWN_LINUX_GNU_LINKER=powerpc-linux-gnu-gcc
export CARGO_TARGET_POWERPC_UNKNOWN_LINUX_GNU_RUNNER="qemu-ppc -L /usr/powerpc-linux-gnu"
export CARGO_TARGET_I686_UNKNOWN_LINUX_GNU_LINKER=i686-linux-gnu-gcc
export CARGO_TARGET_I686_UNKNOWN_LINUX_GNU_RUNNER="qemu-i386 -L /usr/i686-linux-gnu"
export CARGO_TARGET_THUMBV7NEON_UNKNOWN_LINUX_GNUEABIHF_LINKER=arm-linux-gnueabihf-gcc
export CARGO_TARGET_THUMBV7NEON_UNKNOWN_LINUX_GNUEABIHF_RUNNER="qemu-arm -L /usr/arm-linux-gnueabihf"
runtime_tests "$HOST"
for t in "${CROSS_TARGETS[@]}"; do runtime_tests "$t"; done

# ---------------------------------------------------------------------------------------------
section "Cortex-M4 firmware under QEMU"

# The canary builds below share this target directory (their features touch only the firmware
# crate, so dependencies are built once) and overwrite its binaries: every binary checked is
# copied out first.
fw_cargo() { (cd "$ROOT/firmware" && CARGO_TARGET_DIR="$FW_TARGET_DIR" cargo "$@"); }
FW_OUT="$FW_TARGET_DIR/$M4_TARGET/release/facebake-firmware"
ELF="$WORK/facebake-firmware.elf"
run_m4() { timeout 600 "$QEMU_SYSTEM_ARM" -machine mps2-an386 -cpu cortex-m4 -nographic \
    -semihosting-config enable=on,target=native -kernel "$@"; }

if fw_cargo build --locked --release --bin facebake-firmware >"$WORK/fw-build.log" 2>&1; then
    pass "firmware builds for $M4_TARGET"
    cp "$FW_OUT" "$ELF"
    sym() { "$LLVM_BIN/llvm-nm" -C "$ELF" |
        awk -v want="facebake_firmware::$1" '$3 == want || index($3, want "::h") == 1 {print $1}'; }
    START_ADDR=$(sym frame_start)
    END_ADDR=$(sym frame_end)
    rc=0
    run_m4 "$ELF" -plugin "$PLUGIN,start=0x$START_ADDR,end=0x$END_ADDR" -d plugin \
        >"$WORK/fw.out" 2>"$WORK/fw.err" || rc=$?
    grep -v '^frame_insns ' "$WORK/fw.err" >&2 || true
    grep -E '^(figures|firmware|FAIL)' "$WORK/fw.out" || true
    golden_lines() { grep -E '^[a-z0-9_]+ (frame [0-9]+|sequence) [0-9a-f]{16}$' "$1"; }
    if [ "$rc" -ne 0 ]; then
        fail "firmware exited with status $rc under QEMU"
    elif ! grep -qx "firmware: done" "$WORK/fw.out"; then
        fail "firmware did not finish"
    elif ! diff <(cat fixtures/golden/hashes.txt fixtures/golden/hashes_take.txt | golden_lines /dev/stdin) \
        <(golden_lines "$WORK/fw.out") >"$WORK/fw.diff"; then
        head -n 20 "$WORK/fw.diff"
        fail "Cortex-M4 frame hashes differ from hashes.txt and hashes_take.txt"
    else
        pass "Cortex-M4: all $(golden_lines "$WORK/fw.out" | grep -c ' frame ') frame hashes and every sequence hash equal hashes.txt and hashes_take.txt (the packed take played from flash)"
    fi
    # The normals of every frame (the planar rig is not played here).
    if diff <(golden_lines fixtures/golden/hashes_normals.txt | grep -v '^planar ') \
        <(grep '^normals ' "$WORK/fw.out" | sed 's/^normals //') >"$WORK/fw-normals.diff"; then
        pass "Cortex-M4: all $(grep -c '^normals .* frame ' "$WORK/fw.out") normals frame hashes and every sequence hash equal hashes_normals.txt"
    else
        head -n 20 "$WORK/fw-normals.diff"
        fail "Cortex-M4 normals hashes differ from hashes_normals.txt"
    fi

    # Instructions per frame, in firmware order: per deform rig and frame one count for the
    # deform call and one for the normals call, then one per capture frame (the stages).
    mapfile -t ALL_COUNTS < <(awk '/^frame_insns / {print $2}' "$WORK/fw.err")
    FRAMES=$(( $(stat -c %s fixtures/golden/facecap_markers.bin) / (40 * 12) ))
    CAPTURE_FRAMES=$(( $(stat -c %s fixtures/golden/jawmocap_actor.bin) / (41 * 13) ))
    TAKE_FRAMES=$(grep -c '^take frame ' fixtures/golden/hashes_take.txt)
    COUNTS=()
    NORMAL_COUNTS=()
    for j in $(seq 0 $(( 2 * FRAMES * ${#RIGS[@]} - 1 ))); do
        if [ $(( j % 2 )) -eq 0 ]; then COUNTS+=("${ALL_COUNTS[$j]:-}"); else NORMAL_COUNTS+=("${ALL_COUNTS[$j]:-}"); fi
    done
    # Then the capture frames (one count each) and the packed take's (two each).
    COUNTS+=("${ALL_COUNTS[@]:$(( 2 * FRAMES * ${#RIGS[@]} ))}")
    # The plugin's cycle estimate of each of those calls (each executed instruction timed by the
    # Cortex-M4 TRM, firmware/qemu/frame_insns.c), in the same order.
    mapfile -t ALL_CYCLES < <(awk '/^frame_cycles / {print $2}' "$WORK/fw.err")
    CYCLES=()
    for j in $(seq 0 $(( 2 * FRAMES * ${#RIGS[@]} - 1 ))); do
        if [ $(( j % 2 )) -eq 0 ]; then CYCLES+=("${ALL_CYCLES[$j]:-}"); fi
    done
    CYCLES+=("${ALL_CYCLES[@]:$(( 2 * FRAMES * ${#RIGS[@]} ))}")
    EXPECTED_COUNTS=$(( 2 * FRAMES * ${#RIGS[@]} + CAPTURE_FRAMES + 2 * TAKE_FRAMES ))
    if [ "${#ALL_COUNTS[@]}" -ne "$EXPECTED_COUNTS" ]; then
        fail "instruction counter saw ${#ALL_COUNTS[@]} calls, expected $EXPECTED_COUNTS"
    else
        # Rig::normals: the same count for the 32 truth frames and the rest pose (positions
        # within ±2 rig units), more but bounded when the saturated poses clamp the edges.
        inside=$(printf '%s\n' "${NORMAL_COUNTS[@]:0:33}" | sort -u)
        worst=$(printf '%s\n' "${NORMAL_COUNTS[@]}" | sort -n | tail -n 1)
        if [ "$(wc -l <<<"$inside")" -eq 1 ] && [ $(( 2 * worst )) -le $(( 3 * inside )) ]; then
            pass "Cortex-M4 normals: $inside instructions in every truth and rest frame, at most $worst with clamped edges"
            figure "M4 normals, 2694 vertices: $inside instructions per frame = $(awk -v i="$inside" 'BEGIN {printf "%.2f", i / 168e3}') ms at 168 MHz (the weights rig's deform: ${COUNTS[FRAMES]})"
        else
            fail "Cortex-M4 normals: instructions per frame $(printf '%s\n' "${NORMAL_COUNTS[@]}" | sort -u | tr '\n' ' ')"
        fi
        # The packed take comes last, two counts a frame: decoding it, then deforming it.
        TAKE_AT=$(( FRAMES * ${#RIGS[@]} + CAPTURE_FRAMES ))
        printf '%s\n' "${COUNTS[@]:$TAKE_AT}" | awk 'NR % 2 == 1' | sort -n >"$WORK/take-decode"
        printf '%s\n' "${COUNTS[@]:$TAKE_AT}" | awk 'NR % 2 == 0' | sort -n >"$WORK/take-deform"
        read -r DEC_MIN DEC_MED DEC_MAX < <(awk '{ v[NR] = $1 } END { print v[1], v[int((NR + 1) / 2)], v[NR] }' "$WORK/take-decode")
        read -r DEF_MIN DEF_MAX < <(awk 'NR == 1 { lo = $1 } { hi = $1 } END { print lo, hi }' "$WORK/take-deform")
        DEC_MAX_CYCLES=$(printf '%s\n' "${CYCLES[@]:$TAKE_AT}" | awk 'NR % 2 == 1' | sort -n | tail -n 1)
        figure "M4 packed take (41 markers): decoding $DEC_MIN to $DEC_MAX instructions per frame (median $DEC_MED; at most $DEC_MAX_CYCLES cycles) over $TAKE_FRAMES frames; the capture rig's stages + deformation (FaceCap, 2694 vertices) $DEF_MIN to $DEF_MAX: decoding at most $(awk -v d="$DEC_MAX" -v f="$DEF_MIN" 'BEGIN { printf "%.2f", 100 * d / f }')% of that frame, median $(awk -v d="$DEC_MED" -v f="$DEF_MIN" 'BEGIN { printf "%.2f", 100 * d / f }')% (against the deformation alone: below)"
        # The capture stages (41 markers) come last; their work depends on which markers are
        # missing, so report the spread.
        read -r STAGES_MIN STAGES_MED STAGES_MAX < <(
            printf '%s\n' "${COUNTS[@]:$(( FRAMES * ${#RIGS[@]} )):$CAPTURE_FRAMES}" | sort -n |
                awk '{ v[NR] = $1 } END { print v[1], v[int((NR + 1) / 2)], v[NR] }')
        STAGES_MAX_CYCLES=$(printf '%s\n' "${CYCLES[@]:$(( FRAMES * ${#RIGS[@]} )):$CAPTURE_FRAMES}" | sort -n | tail -n 1)
        WEIGHTS_CYCLES=$(printf '%s\n' "${CYCLES[@]:$FRAMES:$FRAMES}" | sort -n | tail -n 1)
        figure "M4 capture stages, 41 markers: $STAGES_MIN to $STAGES_MAX instructions per frame (median $STAGES_MED) over $CAPTURE_FRAMES frames; at most $STAGES_MAX_CYCLES cycles (TRM estimate) = $(awk -v c="$STAGES_MAX_CYCLES" 'BEGIN { printf "%.2f", c / 168e3 }') ms at 168 MHz"
        for i in "${!RIGS[@]}"; do
            distinct=$(printf '%s\n' "${COUNTS[@]:$(( i * FRAMES )):$FRAMES}" | sort -u)
            if [ "$(wc -l <<<"$distinct")" -eq 1 ]; then
                M4_INSNS[${RIGS[$i]}]=$distinct
                pass "Cortex-M4 ${RIGS[$i]}: $distinct instructions in every one of $FRAMES frames (rest, truth, saturated alike)"
            else
                fail "Cortex-M4 ${RIGS[$i]}: instructions per frame vary: $(tr '\n' ' ' <<<"$distinct")"
            fi
        done
    fi

    # Flash and RAM.
    read -r TEXT DATA BSS < <("$LLVM_BIN/llvm-size" "$ELF" | awk 'NR == 2 {print $1, $2, $3}')
    read -r CODE RODATA < <("$LLVM_BIN/llvm-size" -A "$ELF" |
        awk '$1 == ".text" {t = $2} $1 == ".rodata" {r = $2} END {print t, r}')
    figure "firmware flash $(( TEXT + DATA )) bytes: code $CODE, read-only data $RODATA (the blobs and markers), data $DATA; static RAM $(( DATA + BSS )) bytes; budget 1 MiB flash, 128 KiB RAM (memory.x)"
    for f in fixtures/golden/*.fbk fixtures/golden/*.fbt fixtures/golden/facecap_*markers.bin; do
        figure "$(basename "$f") $(stat -c %s "$f") bytes"
    done
    # Stack: the frames of the path main → Rig::deform (the output buffer is on main's stack).
    "$LLVM_BIN/llvm-objdump" -d --no-show-raw-insn -C "$ELF" | awk '
        function hex(h,   i, d, n) { n = 0; h = tolower(substr(h, 3))
            for (i = 1; i <= length(h); i++) n = n * 16 + index("0123456789abcdef", substr(h, i, 1)) - 1
            return n }
        /^[0-9a-f]+ </ { fn = $0; sub(/^[0-9a-f]+ </, "", fn); sub(/>:$/, "", fn); sub(/::h[0-9a-f]+$/, "", fn) }
        /\tsub(\.w)?\tsp, (sp, )?#0x/ { n = $NF; sub(/^#/, "", n); frame[fn] += hex(n) }
        /\tpush(\.w)?\t\{/ { regs = $0; sub(/.*\{/, "", regs); frame[fn] += 4 * split(regs, r, ",") }
        END {
            m = frame["facebake_firmware::__cortex_m_rt_main"]; d = frame["facebake_runtime::rig::Rig::deform"]
            printf "FIGURE: stack: main %d bytes (holds the 3072-vertex output buffer), Rig::deform %d bytes (marker and coefficient scratch); main + deform %d bytes of the 128 KiB RAM\n", m, d, m + d
        }'
else
    cat "$WORK/fw-build.log"
    fail "firmware build"
fi

# A panic must fail the check: the panic canary must report and exit non-zero.
if fw_cargo build --locked --release --bin facebake-firmware --features panic-canary \
    >"$WORK/panic-build.log" 2>&1; then
    rc=0
    run_m4 "$FW_OUT" >"$WORK/panic.out" 2>&1 || rc=$?
    if [ "$rc" -ne 0 ] && grep -q "FAIL: firmware panicked" "$WORK/panic.out"; then
        pass "a firmware panic is reported over semihosting and exits non-zero ($rc)"
    else
        cat "$WORK/panic.out"
        fail "the panic canary exited $rc"
    fi
else
    cat "$WORK/panic-build.log"
    fail "panic canary build"
fi

# ---------------------------------------------------------------------------------------------
section "never allocates: no allocator in the firmware"

if fw_cargo build --locked --release --bin facebake-firmware --features alloc-canary \
    >"$WORK/alloc.log" 2>&1; then
    fail "firmware with alloc-canary linked: an allocation would go unnoticed"
elif grep -q "no global memory allocator found" "$WORK/alloc.log"; then
    pass "firmware using alloc fails to link (no global allocator), the real firmware links"
else
    cat "$WORK/alloc.log"
    fail "alloc-canary build failed for another reason"
fi

# ---------------------------------------------------------------------------------------------
section "no float on the load and per-frame path ($NOFPU_TARGET, no FPU)"

SOFT_FLOAT='^(__aeabi_(f|d|[ui]?l?2[fd]|[fd]2)|__(add|sub|mul|div|neg|cmp|eq|ne|lt|le|gt|ge|unord|pow[i]?)[sdt]f[23]|__(fix|float)(uns)?[sdt]?[sdt]?[sdti]f|__(extend|trunc)[sdt]f)'
soft_float_symbols() { "$LLVM_BIN/llvm-nm" "$1" | awk '{print $NF}' | grep -E "$SOFT_FLOAT" || true; }
NF="$FW_TARGET_DIR/$NOFPU_TARGET/release/nofloat"
NF_CANARY="$WORK/nofloat-canary.elf"
if fw_cargo build --locked --release --bin nofloat --target "$NOFPU_TARGET" --features float-canary \
    >"$WORK/nf.log" 2>&1 && cp "$NF" "$NF_CANARY" &&
    fw_cargo build --locked --release --bin nofloat --target "$NOFPU_TARGET" >>"$WORK/nf.log" 2>&1; then
    found=$(soft_float_symbols "$NF")
    canary=$(soft_float_symbols "$NF_CANARY")
    if [ -z "$canary" ]; then
        fail "the float canary links no soft-float symbol: the check cannot see floats"
    elif [ -n "$found" ]; then
        fail "Rig::from_bytes + Rig::deform link soft-float routines: $(tr '\n' ' ' <<<"$found")"
    # (grep the saved symbols: under pipefail, `llvm-nm | grep -q` fails when grep stops early.)
    # (the payload decoder, or the stages' validation when the decoder is inlined into its caller)
    elif ! "$LLVM_BIN/llvm-nm" -C "$NF" >"$WORK/nf.syms" ||
        ! grep -qE "facebake_runtime::(format::decode|stages::Stages::validate)" "$WORK/nf.syms"; then
        fail "the nofloat harness does not contain the runtime's loader"
    else
        pass "Rig::from_bytes + Rig::deform link no soft-float routine (the canary links $(tr '\n' ' ' <<<"$canary"))"
    fi
else
    cat "$WORK/nf.log"
    fail "nofloat harness build"
fi

# ---------------------------------------------------------------------------------------------
section "bounded cost: host instructions per frame (callgrind)"

if cargo build -q --release -p facebake-runtime --example frame_cost >"$WORK/fc.log" 2>&1; then
    FC="$CARGO_TARGET_DIR/release/examples/frame_cost"
    for rig in "${RIGS[@]}"; do
        per_class=()
        for poses in truth rest extreme; do
            out="$WORK/cg.$rig.$poses"
            valgrind --tool=callgrind --toggle-collect='*deform_frame*' \
                --callgrind-out-file="$out" "$FC" "$rig" "$poses" >"$out.log" 2>&1
            total=$(awk '/^(summary|totals):/ {print $2; exit}' "$out")
            per_class+=("$poses=$(( total / 32 ))")
            HOST_IR[$rig.$poses]=$(( total / 32 ))
        done
        read -r _ influences <<<"$("$FC" "$rig" rest | awk '{print $1, $(NF-1)}')"
        if [ "${HOST_IR[$rig.truth]}" -gt 0 ] &&
            [ "${HOST_IR[$rig.truth]}" -eq "${HOST_IR[$rig.rest]}" ] &&
            [ "${HOST_IR[$rig.truth]}" -eq "${HOST_IR[$rig.extreme]}" ]; then
            pass "host $rig: ${HOST_IR[$rig.truth]} instructions per frame for truth, rest and extreme poses alike"
            figure "host ($HOST) $rig: ${HOST_IR[$rig.truth]} Ir/frame, $(awk -v i="${HOST_IR[$rig.truth]}" -v n="$influences" 'BEGIN {printf "%.1f", i / n}') Ir per vertex-influence ($influences influences)"
        else
            fail "host $rig: instructions per frame depend on the markers: ${per_class[*]}"
        fi
    done
    # Instructions per frame of `frame_cost weights <poses> <mode>` inside the function
    # `<mode>_frame` (normals_frame, planned_frame).
    frame_ir() {
        local out="$WORK/cg.$1.$2"
        valgrind --tool=callgrind --toggle-collect="*$2_frame*" \
            --callgrind-out-file="$out" "$FC" weights "$1" "$2" >"$out.log" 2>&1
        echo $(( $(awk '/^(summary|totals):/ {print $2; exit}' "$out") / 32 ))
    }
    # Rig::normals: the same work for every pose inside ±2 rig units (truth and rest), more but
    # bounded (the edge clamps) when a position is beyond; never more than 1.5x the unclamped.
    # Rig::normals_planned: the same normals (tests/tests/normals.rs), each triangle's cross
    # product once; the same work for truth and rest, the fans' beyond ±2 rig units.
    declare -A NORMALS_IR PLANNED_IR
    for poses in truth rest extreme; do
        NORMALS_IR[$poses]=$(frame_ir "$poses" normals)
    done
    for poses in truth rest; do
        PLANNED_IR[$poses]=$(frame_ir "$poses" planned)
    done
    if [ "${NORMALS_IR[truth]}" -gt 0 ] &&
        [ "${NORMALS_IR[truth]}" -eq "${NORMALS_IR[rest]}" ] &&
        [ $(( 2 * NORMALS_IR[extreme] )) -le $(( 3 * NORMALS_IR[truth] )) ]; then
        pass "host normals: ${NORMALS_IR[truth]} instructions per frame for truth and rest alike, ${NORMALS_IR[extreme]} for extreme poses (edges clamped)"
        figure "host ($HOST) normals: ${NORMALS_IR[truth]} Ir/frame ($(awk -v i="${NORMALS_IR[truth]}" -v d="${HOST_IR[weights.truth]:-0}" 'BEGIN {printf "%.2f", (d > 0 ? i / d : 0)}') x the weights rig's deform), ${NORMALS_IR[extreme]} with clamped edges"
    else
        fail "host normals: instructions per frame truth=${NORMALS_IR[truth]} rest=${NORMALS_IR[rest]} extreme=${NORMALS_IR[extreme]}"
    fi
    if [ "${PLANNED_IR[truth]}" -gt 0 ] && [ "${PLANNED_IR[truth]}" -eq "${PLANNED_IR[rest]}" ] &&
        [ "${PLANNED_IR[truth]}" -lt "${NORMALS_IR[truth]}" ]; then
        pass "host planned normals: ${PLANNED_IR[truth]} instructions per frame for truth and rest alike, fewer than the fans'"
        figure "host ($HOST) planned normals: ${PLANNED_IR[truth]} Ir/frame ($(awk -v p="${PLANNED_IR[truth]}" -v f="${NORMALS_IR[truth]}" 'BEGIN {printf "%.2f", p / f}') x the fans')"
    else
        fail "host planned normals: instructions per frame truth=${PLANNED_IR[truth]} rest=${PLANNED_IR[rest]} (fans ${NORMALS_IR[truth]})"
    fi
else
    cat "$WORK/fc.log"
    fail "frame_cost example build"
fi

# ---------------------------------------------------------------------------------------------
section "what a frame costs on a 168 MHz Cortex-M4"

if [ -n "${M4_INSNS[coefficients]:-}" ] && [ -n "${M4_INSNS[coefficients_k4]:-}" ]; then
    # Coefficients form: insns ≈ V × (a + K·b). The K = 8 and K = 4 rigs share everything but K,
    # so b = (I8 − I4) / (4V); a takes the per-vertex work plus the (small) per-frame stage 1.
    awk -v i8="${M4_INSNS[coefficients]}" -v i4="${M4_INSNS[coefficients_k4]}" -v v=2694 'BEGIN {
        b = (i8 - i4) / (4 * v); a = i4 / v - 4 * b
        printf "FIGURE: M4 coefficients form: %.1f instructions per vertex + %.1f per influence (from K = 8: %d, K = 4: %d per frame, 2694 vertices)\n", a, b, i8, i4
    }'
fi

if [ -n "${M4_INSNS[product]:-}" ] && [ -n "${M4_INSNS[weights]:-}" ]; then
    # What `facebake bake` makes with no options: the linear deformer at K = 8 with derived
    # markers (the mouth's projections, the followed markers' mean) on 41 markers.
    awk -v p="${M4_INSNS[product]}" -v w="${M4_INSNS[weights]}" 'BEGIN {
        printf "FIGURE: M4 product default rig (41 markers, derived markers, K = 8, 2694 vertices): %d instructions per frame, %.3f x the weights rig (%d)\n", p, p / w, w
    }'
fi

# The default rig (the weights form, the linear deformer) plus the capture stages, for a frame of
# 2,000 vertices at K = 4 and of 10,000 at K = 8, in cycles estimated from the Cortex-M4 TRM's
# instruction timings (DDI 0439, section 3.3; the classes and the pipelining rules are listed at
# the top of firmware/qemu/frame_insns.c, which times every instruction QEMU executes the same
# way). On the Cortex-M4 the linear deformer's vertex loops for K = 4 and K = 8 are Thumb-2
# assembly (`deformer::linear::m4`), four vertices a pass:
#   * per vertex: each loop's instructions and cycles, read from the firmware's disassembly (the
#     backward branches in `linear::portable::deform` whose bodies hold SMLAD/SMUAD: 12 a pass
#     for K = 4, 24 for K = 8, both must be there) with the same timings, divided by the four
#     vertices of a pass;
#   * per frame: the rest of the measured FaceCap K = 8 frame (its cycles less 2694 vertices'
#     worth of the loop: the marker quantisation and the marker pair table);
#   * the capture stages: the most cycles any of their measured frames took.
# Memory is taken as zero-wait-state and every access aligned (the baker aligns the sections
# the loop reads, and the firmware asserts it).
if [ -n "${M4_INSNS[weights]:-}" ] && [ -n "${STAGES_MAX:-}" ] && [ -n "${WEIGHTS_CYCLES:-}" ] &&
    [ -n "${STAGES_MAX_CYCLES:-}" ] && [ -f "${ELF:-}" ]; then
    mapfile -t LOOPS < <("$LLVM_BIN/llvm-objdump" -d --no-show-raw-insn -C "$ELF" | awk '
        function hex(h,   i, n) { n = 0; h = tolower(h); sub(/^0x/, "", h)
            for (i = 1; i <= length(h); i++) n = n * 16 + index("0123456789abcdef", substr(h, i, 1)) - 1
            return n }
        function single_load(m) { return m ~ /^ldr(b|h|sb|sh)?$/ }
        function memory(m) { return m ~ /^(ldr|str|ldm|stm|push|pop)/ }
        function address(s) { return match(s, /\[[^]]*\]/) ? substr(s, RSTART, RLENGTH) : "" }
        function uses(s, r) { return r != "" && s ~ ("(^|[^a-z0-9])" r "([^a-z0-9]|$)") }
        function cycles(i, last,   m, p, c) {
            m = op[i]; p = op[i - 1]
            if (i == last) return 1 + 2
            if (single_load(m)) c = (single_load(p) && !uses(address(arg[i]), dst[i - 1])) ? 1 : 2
            else if (m ~ /^str(b|h)?$/) c = 1
            else if (m ~ /^(ldrd|strd)$/) c = 3
            else if (m ~ /^(mla|mls)$/) c = 2
            else c = 1
            if (memory(m) && !memory(p) && p !~ /^b/ && uses(address(arg[i]), dst[i - 1])) c++
            return c
        }
        /^[0-9a-f]+ </ { inside = $0 ~ /linear::portable::deform/; next }
        inside && /^ *[0-9a-f]+:/ {
            split($0, f, "\t"); a = f[1]; sub(/:.*/, "", a); gsub(/ /, "", a)
            n++; addr[n] = hex(a); op[n] = f[2]; sub(/\.(w|n)$/, "", op[n]); arg[n] = f[3]
            dst[n] = arg[n]; sub(/[,{].*/, "", dst[n]); gsub(/ /, "", dst[n])
            if (op[n] ~ /^b(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le)?$/ && match(arg[n], /0x[0-9a-f]+/)) {
                t = hex(substr(arg[n], RSTART, RLENGTH))
                if (t < addr[n]) {
                    first = 0; dual = 0
                    for (i = n; i >= 1 && addr[i] >= t; i--) { first = i; dual += (op[i] ~ /^sm(la|ua)d$/) }
                    if (dual > 0) {
                        c = 0
                        for (i = first; i <= n; i++) c += cycles(i, n)
                        print dual, n - first + 1, c
                    }
                }
            }
        }')
    # One loop per kernel: 12 dual multiplies a pass for K = 4 (two pairs, four vertices), 24 for K = 8.
    read -r K4_INSNS K4_CYCLES < <(printf '%s\n' "${LOOPS[@]}" | awk '$1 == 24 {print $2, $3}')
    read -r K8_INSNS K8_CYCLES < <(printf '%s\n' "${LOOPS[@]}" | awk '$1 == 48 {print $2, $3}')
    # (The Rust loop for other counts has loops of its own, with 3 dual multiplies each.)
    KERNELS=$(printf '%s\n' "${LOOPS[@]}" | awk '$1 == 24 || $1 == 48' | wc -l)
    if [ "$KERNELS" -ne 2 ] || [ -z "${K4_INSNS:-}" ] || [ -z "${K8_INSNS:-}" ]; then
        fail "the linear deformer's Cortex-M4 kernels: expected one K = 4 and one K = 8 loop in the firmware, found: ${LOOPS[*]:-none}"
    else
        awk -v iw="${M4_INSNS[weights]}" -v cw="$WEIGHTS_CYCLES" -v v=2694 -v i4="$K4_INSNS" \
            -v c4="$K4_CYCLES" -v i8="$K8_INSNS" -v c8="$K8_CYCLES" -v stages="$STAGES_MAX" \
            -v stages_cycles="$STAGES_MAX_CYCLES" 'BEGIN {
            frame = iw - v * i8 / 4; frame_cycles = cw - v * c8 / 4
            printf "FIGURE: M4 weights form (linear deformer): per vertex %.2f instructions and %.2f cycles at K = 4, %.2f and %.2f at K = 8 (a four-vertex pass: %d / %d and %d / %d); per frame %d instructions, %d cycles (FaceCap K = 8: %d instructions, %d cycles a frame, 2694 vertices)\n", i4 / 4, c4 / 4, i8 / 4, c8 / 4, i4, c4, i8, c8, frame, frame_cycles, iw, cw
            n = split("2000 4 10000 8", c, " ")
            for (j = 1; j < n; j += 2) {
                vv = c[j]; kk = c[j + 1]
                vi = (kk == 4) ? i4 / 4 : i8 / 4; vc = (kk == 4) ? c4 / 4 : c8 / 4
                deform = vv * vi + frame; ins = deform + stages
                deform_cycles = vv * vc + frame_cycles; cyc = deform_cycles + stages_cycles
                ms = cyc / 168e6 * 1e3
                printf "FIGURE: M4 estimate %d vertices, K = %d, with the capture stages: %.0f instructions (deform %.0f + stages %d), ~%.0f cycles (deform %.0f + stages %d, stages %.1f%%) = %.2f ms at 168 MHz, %.1f%% of a 16.7 ms frame\n", vv, kk, ins, deform, stages, cyc, deform_cycles, stages_cycles, 100 * stages_cycles / cyc, ms, 100 * ms / (1000 / 60)
                if (kk == 8) print (cyc <= 700000) ? "WITHIN" : "OVER", cyc > "/dev/stderr"
            }
        }' 2> "$WORK/m4-budget"
        # A packed take's decoding against the deformation it feeds: the FaceCap K = 8 frame
        # alone (the rig the firmware plays the take on, without its capture stages), the
        # smallest of the frames it could be measured against. At most 5 % of it.
        BUDGET_CYCLES=$(awk '{print $2}' "$WORK/m4-budget")
        share() { awk -v d="$1" -v f="$2" 'BEGIN { printf "%.2f", 100 * d / f }'; }
        if [ -n "${DEC_MAX_CYCLES:-}" ] && [ -n "${WEIGHTS_CYCLES:-}" ] &&
            [ $(( DEC_MAX_CYCLES * 20 )) -le "$WEIGHTS_CYCLES" ]; then
            pass "Cortex-M4: decoding a packed take frame (at most $DEC_MAX_CYCLES cycles) costs at most 5% of the FaceCap K = 8 deformation it feeds ($(share "$DEC_MAX_CYCLES" "$WEIGHTS_CYCLES")% of $WEIGHTS_CYCLES cycles; $(share "$DEC_MAX_CYCLES" "$BUDGET_CYCLES")% of the 10,000-vertex budget frame)"
        else
            fail "Cortex-M4: decoding a packed take frame (${DEC_MAX_CYCLES:-?} cycles) costs more than 5% of the FaceCap K = 8 deformation (${WEIGHTS_CYCLES:-?} cycles)"
        fi
        if grep -q '^WITHIN' "$WORK/m4-budget"; then
            pass "Cortex-M4 budget: a 10,000-vertex K = 8 frame with the capture stages in $(awk '{print $2}' "$WORK/m4-budget") cycles (estimate), within 700,000 (25% of a 60 fps frame at 168 MHz)"
        else
            fail "Cortex-M4 budget: a 10,000-vertex K = 8 frame with the capture stages in $(awk '{print $2}' "$WORK/m4-budget") cycles (estimate), over 700,000"
        fi
    fi
else
    fail "no Cortex-M4 counts for the weights rig and the capture stages to estimate from"
fi

section "done"
echo "cross.sh took $((SECONDS - START)) s"
echo "$PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
