#!/usr/bin/env bash
# Two builds of `render` side by side in one run: for each blob, scalar and wavefront, one thread,
# the two binaries alternating ROUNDS times; CPU seconds (user + sys) per render, then mean and
# minimum per (scene, integrator, binary). For refactors that must keep speed level.
#   scripts/bench-ab.sh OLD_RENDER NEW_RENDER BLOB... > ab.md
# Blobs: the `bench integrators` scenes land in out/bench/ (tractor, shading-heavy, material-heavy,
# simple). Settings: RES (320x213), SPP (16), ROUNDS (5). Needs GNU time (Debian package `time`).
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: $0 OLD_RENDER NEW_RENDER BLOB..." >&2; exit 2; }
old=$1 new=$2; shift 2
res=${RES:-320x213} spp=${SPP:-16} rounds=${ROUNDS:-5}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
for round in $(seq "$rounds"); do
    for blob in "$@"; do
        for integrator in scalar wavefront; do
            for which in old new; do
                bin=$old; [ $which = new ] && bin=$new
                /usr/bin/time -o "$work/t" -f "%U %S" "$bin" "$blob" -o "$work/out.exr" --res "$res" \
                    --spp "$spp" --threads 1 --integrator "$integrator" >/dev/null 2>&1
                echo "$(basename "$blob" .blob) $integrator $which $(awk '{print $1 + $2}' "$work/t")"
            done
        done
    done
done > "$work/runs"
echo "| scene | integrator | old mean | new mean | old min | new min | new/old (mean) |"
echo "|---|---|---|---|---|---|---|"
awk '{k = $1 " " $2; s[k, $3] += $4; n[k, $3]++; if (!((k, $3) in m) || $4 < m[k, $3]) m[k, $3] = $4; keys[k] = 1}
     END { for (k in keys) { split(k, p, " "); o = s[k, "old"] / n[k, "old"]; w = s[k, "new"] / n[k, "new"];
           printf "| %s | %s | %.3f | %.3f | %.3f | %.3f | %.3f |\n", p[1], p[2], o, w, m[k, "old"], m[k, "new"], w / o } }' \
    "$work/runs" | sort
