#!/usr/bin/env bash
# Runs the kernel tests on emulated CPUs without AVX2, so the baseline clones of the `multiversion`
# kernels (and `half`'s software f16 decoding) are tested, not only compiled: the machines we develop
# and test on have AVX2, FMA and F16C, which a user's older CPU may lack.
#
# Under qemu-user (`qemu-x86_64 -cpu MODEL`, Debian's qemu-user; TCG raises SIGILL on any instruction
# the model lacks), for a model without AVX (Nehalem) and one with AVX but no AVX2/FMA (SandyBridge):
#   - render's lane and traversal kernel tests (bit-exact against the scalar code), the integrator
#     equivalence tests (wavefront == scalar image) and a dispatch test that asserts the baseline
#     clones were picked (RENDER_EMULATED_CPU tells it which features the model has);
#   - texture's tests, the half-float test over all 65,536 patterns among them.
# Then the images the equivalence tests rendered natively (AVX2 clones) and emulated (baseline clones)
# must be the same bytes, and so must the bundled example rendered by the `render` binary with both
# integrators on both CPUs.
#
# Assumes scripts/setup.sh ran (qemu-user).
set -euo pipefail
cd "$(dirname "$0")/.."

if [ "$(uname -m)" != x86_64 ]; then
    echo "test-fallback: not an x86_64 machine; nothing to emulate"
    exit 0
fi
if ! command -v qemu-x86_64 >/dev/null 2>&1; then
    echo "error: qemu-x86_64 not found; run scripts/setup.sh (Debian package qemu-user)" >&2
    exit 1
fi

# Executables as scripts/test.sh builds them (the same cargo commands here recompile nothing): the lib
# test binaries of render and texture, and the ingest and render programs.
list_executables() {
    python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable"):
        suffix = "-tests" if m["profile"]["test"] else ""
        print(m["target"]["name"] + "/" + m["target"]["kind"][0] + suffix, m["executable"])'
}
binaries=$(
    cargo build --release --locked -p ingest -p render --message-format=json | list_executables
    cargo test --release --locked --workspace --no-run --message-format=json | list_executables
)
pick() { awk -v name="$1" '$1 == name { print $2 }' <<<"$binaries" | tail -1; }
render_tests=$(pick render/lib-tests) texture_tests=$(pick texture/lib-tests)
render_bin=$(pick render/bin) ingest_bin=$(pick ingest/bin)
if [ -z "$render_tests" ] || [ -z "$texture_tests" ] || [ -z "$render_bin" ] || [ -z "$ingest_bin" ]; then
    echo "error: cargo did not list the render and texture test binaries and the ingest and render programs" >&2
    exit 1
fi

# Tests of code under `multiversion` and of what calls it, by name (libtest: any substring matches).
# Left out for time: trig's accuracy sweeps (scalar code, 2^24 arguments) and the accel tests on big
# instanced or bundled scenes; the equivalence renders cover instanced and plain traversal.
render_filters=(
    dispatch_tests::
    wavefront::
    bsdf::lanes::
    hair::lanes::
    lights::lanes::
    lights::emission_lanes::
    lights::mis::
    sampler::lanes::
    shading::lanes::
    shading::sort_key::
    surface::lanes::
    path::roulette::
    accel::tests::simd_kernels_equal_scalar_kernels
    accel::tests::branch_free_watertight_ray_equals_the_branchy_construction
    accel::tests::bvh_agrees_with_brute_force_on_10000_random_rays
    accel::tests::exact_ties_go_to_the_lowest_triangle_index
    accel::tests::any_hit_calls_blocks_and_skips_non_blockers
    accel::tests::watertight
    accel::tests::shared_edge_is_watertight
    accel::tests::instance_normals_use_the_inverse_transpose
    trig::tests::lanes_equal_scalar_bit_for_bit
    trig::tests::exact_at_zero_and_nan_outside_the_domain
    camera::tests::
    sampler::tests::fast_sampler_equals_the_reference_formulation_bit_for_bit
    sampler::tests::table_free_sobol1_matches_the_bit_serial_reference
    surface::surface_tests::
    lights::tests::escaped_emission_of_many_rays_equals_the_scalar_one
    lights::tree::tests::
    lights::tests::culled_area_emission_equals_the_sum_over_every_light
    shading::tests::small_register_file_equals_the_full_one
    dome_tests::wavefront_image_equals_the_scalar_one_under_a_textured_dome
)

# A renamed test would silently drop out of the selection: every name must still match.
for filter in "${render_filters[@]}"; do
    if ! grep -q ': test$' <<<"$("$render_tests" --list "$filter")"; then
        echo "error: no render test matches \"$filter\"; update render_filters in $0" >&2
        exit 1
    fi
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# qemu-user warns about host-only features of some models (x2apic, tsc-deadline); the rest is kept.
quiet_qemu() { grep -v "TCG doesn't support requested feature" >&2; }

echo "test-fallback: native run (records the equivalence images)"
mkdir -p "$work/native"
RENDER_TEST_IMAGE_DIR="$work/native" "$render_tests" -q --test-threads=2 "${render_filters[@]}"
recorded=$(ls "$work/native" | wc -l)
if [ "$recorded" -lt 8 ]; then
    echo "error: the equivalence tests recorded $recorded images, expected at least 8" >&2
    exit 1
fi

"$ingest_bin" -q examples/tractor.usda -o "$work/tractor.blob"
mkdir -p "$work/logs"
render_example() { # OUT.exr INTEGRATOR [EMULATOR...]
    local out=$1 integrator=$2 log
    shift 2
    log="$work/logs/$(basename "$(dirname "$out")")-$integrator.log"
    if ! "$@" "$render_bin" "$work/tractor.blob" -o "$out" --res 96x72 --spp 8 --threads 2 \
        --integrator "$integrator" >"$log" 2>&1; then
        cat "$log" >&2
        echo "error: render failed: $* $render_bin ... --integrator $integrator" >&2
        return 1
    fi
}
for integrator in wavefront scalar; do
    render_example "$work/native/tractor-$integrator.exr" "$integrator"
done

# No kernel has an AVX-without-AVX2 clone today, so SandyBridge runs the same baseline clones as
# Nehalem; it is there for code that checks AVX alone, and for such a clone if one is ever added.
for model in Nehalem:no-avx SandyBridge:avx-no-avx2; do
    cpu=${model%%:*} features=${model#*:}
    start=$SECONDS
    echo "test-fallback: qemu-x86_64 -cpu $cpu ($features)"
    mkdir -p "$work/$cpu"
    export RENDER_EMULATED_CPU=$features RENDER_TEST_IMAGE_DIR="$work/$cpu"
    qemu-x86_64 -cpu "$cpu" "$render_tests" -q --test-threads=2 dispatch_tests:: --nocapture 2> >(quiet_qemu)
    qemu-x86_64 -cpu "$cpu" "$render_tests" -q --test-threads=2 "${render_filters[@]}" 2> >(quiet_qemu)
    qemu-x86_64 -cpu "$cpu" "$texture_tests" -q --test-threads=2 2> >(quiet_qemu)
    qemu-x86_64 -cpu "$cpu" "$texture_tests" -q emulated_cpus_convert_without_f16c --nocapture 2> >(quiet_qemu)
    unset RENDER_EMULATED_CPU RENDER_TEST_IMAGE_DIR
    for integrator in wavefront scalar; do
        render_example "$work/$cpu/tractor-$integrator.exr" "$integrator" qemu-x86_64 -cpu "$cpu"
    done
    # The same bits from the AVX2 and the baseline clones, for every recorded image.
    if ! diff -r "$work/native" "$work/$cpu"; then
        echo "error: images rendered on $cpu differ from the native ones" >&2
        exit 1
    fi
    cmp "$work/native/tractor-wavefront.exr" "$work/native/tractor-scalar.exr"
    echo "test-fallback: $cpu: $(ls "$work/$cpu" | wc -l) images equal to the native ones bit for bit ($((SECONDS - start)) s)"
done
