#!/usr/bin/env bash
# What splitting a frame into farm units costs, measured side by side in one run on this machine:
# the same frame as 1 process, as 1, 2 and 4 tiles (`render --tile I/N`, run one after another) and
# as a 2-way sample split (`--sample-range`), each followed by `render merge`. Prints a markdown table
# (wall and CPU seconds, and the units' total over the single render) and the per-unit fixed cost
# (map, validate, first ray: a 1×1, 1-spp render); OUT (default docs/bench-farm.md) gets the same.
#   scripts/bench-farm.sh [BLOB] [OUT]      (BLOB default: the tractor example, ingested first)
# Settings: RES (512x512), SPP (64), THREADS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
res=${RES:-512x512} spp=${SPP:-64} threads=${THREADS:-2}
out=${2:-docs/bench-farm.md}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
render=target/release/render
[ -x "$render" ] && [ -x target/release/ingest ] || cargo build --release -p ingest -p render
blob=${1:-}
if [ -z "$blob" ]; then blob=$work/tractor.blob; target/release/ingest examples/tractor.usda -o "$blob" >/dev/null 2>&1; fi
# Wall and CPU (user + sys) seconds of one command, appended to $work/t as "wall cpu".
timed() { /usr/bin/time -o "$work/one" -f "%e %U %S" "$@" >/dev/null 2>&1; awk '{print $1, $2 + $3}' "$work/one" >> "$work/t"; }
sum() { awk '{w += $1; c += $2} END {printf "%.3f %.3f\n", w, c}' "$work/t"; }
common=("$blob" --res "$res" --spp "$spp" --threads "$threads")
: > "$work/t"; timed "$render" "${common[@]}" -o "$work/single.exr"; read -r single_wall single_cpu < <(sum)
: > "$work/t"; timed "$render" "$blob" --res 1x1 --spp 1 --threads 1 -o "$work/fixed.exr"; read -r fixed_wall fixed_cpu < <(sum)
rows=()
for n in 1 2 4; do
    : > "$work/t"
    for ((i = 0; i < n; i++)); do timed "$render" "${common[@]}" --tile "$i/$n" -o "$work/t$n-$i.exr"; done
    timed "$render" merge "$work"/t$n-*.exr -o "$work/merged$n.exr"
    read -r wall cpu < <(sum)
    same=$(cmp -s "$work/merged$n.exr" "$work/single.exr" && echo "byte-equal" || echo "DIFFERS")
    rows+=("| $n tiles + merge | $wall | $cpu | $(awk "BEGIN {printf \"%+.1f %%\", ($wall / $single_wall - 1) * 100}") | $same |")
done
: > "$work/t"
half=$((spp / 2))
timed "$render" "$blob" --res "$res" --threads "$threads" --sample-range "0..$half" -o "$work/s0.exr"
timed "$render" "$blob" --res "$res" --threads "$threads" --sample-range "$half..$spp" -o "$work/s1.exr"
timed "$render" merge "$work/s0.exr" "$work/s1.exr" -o "$work/split.exr"
read -r wall cpu < <(sum)
rows+=("| 2 sample slices + merge | $wall | $cpu | $(awk "BEGIN {printf \"%+.1f %%\", ($wall / $single_wall - 1) * 100}") | within rounding |")
{
    echo "## Farm units against one process ($(date -u +%F), \`scripts/bench-farm.sh\`)"
    echo
    echo "$(basename "$blob"), ${res}, ${spp} spp, ${threads} threads per unit, units run one after another on this machine ($(nproc) cores)."
    echo
    echo "| run | wall s | CPU s | wall vs one process | image |"
    echo "|---|---|---|---|---|"
    echo "| one process | $single_wall | $single_cpu | | |"
    printf '%s\n' "${rows[@]}"
    echo
    echo "Fixed cost of a unit (map, validate, first ray: a 1×1, 1-spp render): ${fixed_wall} s wall, ${fixed_cpu} s CPU."
} | tee "$out"
