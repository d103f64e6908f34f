#!/usr/bin/env bash
# Ours against Blender Cycles and Mitsuba 3 on one scene, side by side: error against time.
#
# Renders bench/peers/make_scene.py's Cornell-like room (USD for us and Cycles, PLY + XML for Mitsuba)
#   - references: Mitsuba llvm_ad_rgb at REF_SPP (the reference), Cycles and ours at OWN_REF_SPP,
#     compared pairwise (do the three agree, or is one biased?);
#   - a sweep spp = 1, 2, 4, … MAX_SPP with ours (wavefront, scalar), Cycles (CPU), Mitsuba scalar_rgb
#     and llvm_ad_rgb (warm JIT cache; cold cache separately: each spp in a fresh process with
#     ~/.drjit emptied), THREADS threads each, best of REPEAT; RMSE of each image against the reference;
# then writes out/bench/peers/peers.json, peers.svg (RMSE vs seconds, log-log) and peers.md (time to
# reach the RMSE of Mitsuba llvm at TARGET_SPP, per renderer).
# The peers live in a venv outside the repository (PEERS_WORK, default ~/.cache/ours-peers), installed
# here on first use; neither render nor the tests need it, and CI does not run this.
# usage: scripts/bench-peers.sh            (env: RES MAX_SPP REF_SPP OWN_REF_SPP REPEAT THREADS
#                                           TARGET_SPP PEERS_WORK PEERS_FRESH=1 to redo the references)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
RES=${RES:-256}
MAX_SPP=${MAX_SPP:-128}
REF_SPP=${REF_SPP:-4096}
OWN_REF_SPP=${OWN_REF_SPP:-1024}
REPEAT=${REPEAT:-2}
THREADS=${THREADS:-2}
TARGET_SPP=${TARGET_SPP:-16}
MAX_DEPTH=8 # Mitsuba's convention: 8 = up to 7 scattering events
WORK=${PEERS_WORK:-$HOME/.cache/ours-peers}
OUT=$ROOT/out/bench/peers
PEERS=$ROOT/bench/peers
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
BIN=$CARGO_TARGET_DIR/release

# ---- peers' venv: usd-core, Mitsuba 3, bpy 5.0.1 (bpy 5.0 wheels exist for Python 3.11 only)
PY=$WORK/venv/bin/python
if ! "$PY" -c 'import bpy, mitsuba, pxr, numpy' 2>/dev/null; then
    mkdir -p "$WORK"
    PY311=$(command -v python3.11 || true)
    [ -n "$PY311" ] || { echo "bench-peers: needs python3.11 (bpy 5.0.1 wheels)" >&2; exit 1; }
    "$PY311" -m venv "$WORK/venv"
    "$PY" -m pip install -q --upgrade pip
    "$PY" -m pip install -q numpy usd-core mitsuba 'bpy==5.0.1'
fi
# Mitsuba's llvm variants need libLLVM >= 16 (Debian bookworm's default 14/15 abort on fminimum).
if ! ls /usr/lib/x86_64-linux-gnu/libLLVM.so.1[6-9]* /usr/lib/x86_64-linux-gnu/libLLVM-1[6-9].so.1 >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && apt-get install -y -qq libllvm19
    else
        echo "bench-peers: install libllvm19 (apt) for Mitsuba's llvm variants" >&2
        exit 1
    fi
fi
cargo build --release --locked -p ingest -p render -p bench
# Set after the build: rustup finds its toolchains through HOME.
export HOME=$WORK/home # Blender's config and Dr.Jit's kernel cache stay in the work folder
mkdir -p "$HOME" "$OUT/sweep" "$OUT/ref"


SPPS=1
s=2
while [ "$s" -le "$MAX_SPP" ]; do SPPS="$SPPS,$s"; s=$((s * 2)); done
echo "bench-peers: ${RES}x${RES}, spp $SPPS, reference $REF_SPP spp, $THREADS threads; load $(cut -d' ' -f1-3 /proc/loadavg)" >&2

"$PY" "$PEERS/make_scene.py" "$OUT/scene" --res "$RES" --max-depth "$MAX_DEPTH" >"$OUT/scene.json"
SCENE_USD=$OUT/scene/scene.usda
SCENE_XML=$OUT/scene/scene_mitsuba.xml
COMMON=(--res "$RES" --max-depth "$MAX_DEPTH" --threads "$THREADS")

# Mean CPU utilisation (CPU-seconds / wall-seconds) of a sweep's renders: 2 threads well under 2.0
# means another process took the cores.
utilisation() { "$PY" -c 'import json,sys; r=[u for l in open(sys.argv[1]) if l.strip() for row in json.loads(l)["rows"] for u in row["cpu_utilisation"]]; print(sum(r)/len(r))' "$1"; }

# run NAME CMD…: one sweep to $OUT/sweep/NAME.json; a contended sweep (utilisation < 80% of THREADS)
# is run once more and the less contended of the two kept.
run() {
    local name=$1
    shift
    echo "+ $name" >&2
    "$@" >"$OUT/sweep/$name.json" 2>"$OUT/sweep/$name.log"
    local u
    u=$(utilisation "$OUT/sweep/$name.json")
    if "$PY" -c "import sys; sys.exit(0 if $u < 0.8 * $THREADS else 1)"; then
        echo "  contended (CPU utilisation $u of $THREADS): running again" >&2
        "$@" >"$OUT/sweep/$name.again.json" 2>>"$OUT/sweep/$name.log"
        if "$PY" -c "import sys; sys.exit(0 if $(utilisation "$OUT/sweep/$name.again.json") > $u else 1)"; then
            mv "$OUT/sweep/$name.again.json" "$OUT/sweep/$name.json"
        else
            rm "$OUT/sweep/$name.again.json"
        fi
    fi
}

# ---- references (each kept across runs unless PEERS_FRESH=1; seeds independent of the sweeps')
[ "${PEERS_FRESH:-0}" = 1 ] && rm -f "$OUT"/ref/*.exr
if [ ! -f "$OUT/ref/reference_$REF_SPP.exr" ]; then
    # 256 spp per pass: one llvm pass holds res² × spp lanes in memory.
    "$PY" "$PEERS/run_mitsuba.py" "$SCENE_XML" --variant llvm_ad_rgb --spp-list 256 --passes $((REF_SPP / 256)) \
        --repeat 1 --seed 1000 --name reference "${COMMON[@]}" --out-dir "$OUT/ref" >"$OUT/ref/mitsuba.json"
fi
if [ ! -f "$OUT/ref/cycles_$OWN_REF_SPP.exr" ]; then
    "$PY" "$PEERS/run_cycles.py" "$SCENE_USD" --spp-list "$OWN_REF_SPP" --repeat 1 --seed 1000 "${COMMON[@]}" \
        --out-dir "$OUT/ref" >"$OUT/ref/cycles.json" 2>"$OUT/ref/cycles.log"
fi
if [ ! -f "$OUT/ref/ours_wavefront_$OWN_REF_SPP.exr" ]; then
    "$PY" "$PEERS/run_ours.py" "$SCENE_USD" --bin-dir "$BIN" --spp-list "$OWN_REF_SPP" --repeat 1 --seed 1000 \
        --name ours_wavefront "${COMMON[@]}" --out-dir "$OUT/ref" >"$OUT/ref/ours.json"
fi

# ---- sweeps
run ours_wavefront "$PY" "$PEERS/run_ours.py" "$SCENE_USD" --bin-dir "$BIN" --integrator wavefront \
    --spp-list "$SPPS" --repeat "$REPEAT" "${COMMON[@]}" --out-dir "$OUT/sweep"
run ours_scalar "$PY" "$PEERS/run_ours.py" "$SCENE_USD" --bin-dir "$BIN" --integrator scalar \
    --spp-list "$SPPS" --repeat "$REPEAT" "${COMMON[@]}" --out-dir "$OUT/sweep"
run cycles "$PY" "$PEERS/run_cycles.py" "$SCENE_USD" --spp-list "$SPPS" --repeat "$REPEAT" "${COMMON[@]}" \
    --out-dir "$OUT/sweep"
run mitsuba_scalar_rgb "$PY" "$PEERS/run_mitsuba.py" "$SCENE_XML" --variant scalar_rgb --spp-list "$SPPS" \
    --repeat "$REPEAT" "${COMMON[@]}" --out-dir "$OUT/sweep"
# Cold JIT: every spp in a fresh process with an empty kernel cache (trace + LLVM compile included).
: >"$OUT/sweep/mitsuba_llvm_cold.json"
for spp in ${SPPS//,/ }; do
    rm -rf "$HOME/.drjit"
    "$PY" "$PEERS/run_mitsuba.py" "$SCENE_XML" --variant llvm_ad_rgb --spp-list "$spp" --repeat 1 \
        --name mitsuba_llvm_ad_rgb_cold_jit "${COMMON[@]}" --out-dir "$OUT/sweep/cold" >>"$OUT/sweep/mitsuba_llvm_cold.json"
done
# Warm: the kernels are in the cache now, and each spp renders REPEAT times in one process.
run mitsuba_llvm_ad_rgb "$PY" "$PEERS/run_mitsuba.py" "$SCENE_XML" --variant llvm_ad_rgb --spp-list "$SPPS" \
    --repeat "$REPEAT" "${COMMON[@]}" --out-dir "$OUT/sweep"

# Mitsuba at its best: the low-discrepancy sampler (the scene's XML asks for `independent`, Mitsuba's
# default). ldsampler rounds the sample count up to a power of 4 (at least 4), so its sweep runs 4, 16, ….
sed 's/<sampler type="independent">/<sampler type="ldsampler">/' "$SCENE_XML" >"${SCENE_XML%.xml}_ldsampler.xml"
LD_SPPS=4
s=16
while [ "$s" -le $((2 * MAX_SPP)) ]; do LD_SPPS="$LD_SPPS,$s"; s=$((s * 4)); done
run mitsuba_llvm_ad_rgb_ldsampler "$PY" "$PEERS/run_mitsuba.py" "${SCENE_XML%.xml}_ldsampler.xml" --variant llvm_ad_rgb \
    --spp-list "$LD_SPPS" --repeat "$REPEAT" --name mitsuba_llvm_ad_rgb_ldsampler "${COMMON[@]}" --out-dir "$OUT/sweep"

"$PY" "$PEERS/score.py" "$OUT"/sweep/{ours_wavefront,ours_scalar,cycles,mitsuba_scalar_rgb,mitsuba_llvm_ad_rgb,mitsuba_llvm_cold,mitsuba_llvm_ad_rgb_ldsampler}.json \
    --reference "$OUT/ref/reference_$REF_SPP.exr" --reference-renderer mitsuba_llvm_ad_rgb --reference-spp "$REF_SPP" \
    --agree "mitsuba_llvm_ad_rgb=$OUT/ref/reference_$REF_SPP.exr@$REF_SPP" \
    --agree "cycles=$OUT/ref/cycles_$OWN_REF_SPP.exr@$OWN_REF_SPP" \
    --agree "ours_wavefront=$OUT/ref/ours_wavefront_$OWN_REF_SPP.exr@$OWN_REF_SPP" \
    --own-reference "cycles=$OUT/ref/cycles_$OWN_REF_SPP.exr" \
    --own-reference "ours_wavefront=$OUT/ref/ours_wavefront_$OWN_REF_SPP.exr" \
    --own-reference "mitsuba_llvm_ad_rgb=$OUT/ref/reference_$REF_SPP.exr" \
    --scene "$(cat "$OUT/scene.json")" --out "$OUT/peers.json" >&2
"$BIN/bench" peers-table "$OUT/peers.json" --target-renderer mitsuba_llvm_ad_rgb --target-spp "$TARGET_SPP" --out "$OUT"
