#!/usr/bin/env bash
# Renders one blob on a Slurm farm: a job array of work units (tiles or sample slices, one task
# each), a merge job that depends on the array (afterok), and a retry job that runs only if a task
# failed (afternotok) and resubmits the missing units once, with their own merge.
#
#   scripts/farm.sh [--tiles N | --samples K] [--cpus C] [--render BIN] [--dry-run] BLOB -o OUT.exr [RENDER OPTION...]
#
#   --tiles N     N bands of rows (render --tile I/N); the merged EXR equals a single render byte for byte
#   --samples K   K sample slices of --spp (render --sample-range A..B); equal within float rounding
#   --cpus C      --cpus-per-task and render --threads (default 1)
#   --render BIN  the render binary every node runs (default: target/release/render beside this script)
#   --dry-run     print the sbatch scripts and commands instead of submitting
#
# Parts go to OUT.parts/ (shared storage, as the blob and OUT must be): each task writes its part
# atomically, so a task that dies leaves no part under its final name, and running the same command
# again submits only the units whose part is missing. Prints the job ids. Any RENDER OPTION (--spp,
# --res, --seed, --crop, ...) is passed to every unit.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tiles=1 samples=1 cpus=1 dry=0 retry=0
render_bin=$here/../target/release/render
blob="" out="" opts=()
while [ $# -gt 0 ]; do
    case "$1" in
        --tiles) tiles=$2; shift 2 ;;
        --samples) samples=$2; shift 2 ;;
        --cpus) cpus=$2; shift 2 ;;
        --render) render_bin=$2; shift 2 ;;
        --dry-run) dry=1; shift ;;
        --retry) retry=1; shift ;; # internal: the retry job's own run (no further retry)
        -o) out=$2; shift 2 ;;
        *) if [ -z "$blob" ] && [[ "$1" != -* ]]; then blob=$1; shift; else opts+=("$1"); shift; fi ;;
    esac
done
fail() { echo "farm: $*" >&2; exit 1; }
[ -n "$blob" ] && [ -n "$out" ] || fail "usage: $0 [--tiles N | --samples K] [--cpus C] [--render BIN] [--dry-run] BLOB -o OUT.exr [RENDER OPTION...]"
[ "$tiles" -ge 1 ] && [ "$samples" -ge 1 ] || fail "--tiles and --samples must be at least 1"
[ "$tiles" -eq 1 ] || [ "$samples" -eq 1 ] || fail "split by --tiles or by --samples, not both"
[ -f "$blob" ] || fail "no blob $blob"
[ -x "$render_bin" ] || fail "no render binary $render_bin (cargo build --release -p render, or --render BIN)"
abs() { (cd "$(dirname "$1")" && echo "$(pwd)/$(basename "$1")"); }
blob=$(abs "$blob") out=$(abs "$out") render_bin=$(abs "$render_bin")
spp=16
for ((i = 0; i < ${#opts[@]}; i++)); do [ "${opts[$i]}" = --spp ] && spp=${opts[$((i + 1))]}; done
[ "$samples" -le "$spp" ] || fail "--samples $samples is more than --spp $spp"

parts=$out.parts jobs=$out.parts/jobs
mkdir -p "$jobs"
units=$((tiles * samples))
# The render options of unit I: its tile, or its slice of the samples (as even as they divide).
unit_args() {
    if [ "$tiles" -gt 1 ]; then echo "--tile $1/$tiles"; fi
    if [ "$samples" -gt 1 ]; then echo "--sample-range $(($1 * spp / samples))..$((($1 + 1) * spp / samples))"; fi
    if [ "$units" -eq 1 ]; then echo "--tile 0/1"; fi
}
missing=()
for ((i = 0; i < units; i++)); do [ -s "$parts/part-$i.exr" ] || missing+=("$i"); done
quoted=$(printf ' %q' "${opts[@]}")

cat > "$jobs/task.sh" <<TASK
#!/usr/bin/env bash
# One work unit: \$SLURM_ARRAY_TASK_ID. render writes the part atomically (temporary + rename).
set -euo pipefail
i=\$SLURM_ARRAY_TASK_ID
case \$i in
$(for ((i = 0; i < units; i++)); do echo "    $i) unit=\"$(unit_args $i)\" ;;"; done)
esac
exec $(printf %q "$render_bin") $(printf %q "$blob") -o $(printf %q "$parts")/part-\$i.exr --threads $cpus$quoted \$unit
TASK
cat > "$jobs/merge.sh" <<MERGE
#!/usr/bin/env bash
set -euo pipefail
exec $(printf %q "$render_bin") merge --blob $(printf %q "$blob") $(for ((i = 0; i < units; i++)); do printf ' %q' "$parts/part-$i.exr"; done) -o $(printf %q "$out")
MERGE
args=$(printf ' %q' --tiles "$tiles" --samples "$samples" --cpus "$cpus" --render "$render_bin" "$blob" -o "$out" "${opts[@]}")
cat > "$jobs/retry.sh" <<RETRY
#!/usr/bin/env bash
# A task of the array failed: resubmit the units whose part is missing, once.
set -euo pipefail
exec bash $(printf %q "$here/farm.sh") --retry$args
RETRY

if [ ${#missing[@]} -eq 0 ]; then
    echo "farm: all $units parts are in $parts; merging"
    if [ $dry -eq 1 ]; then echo "sbatch $jobs/merge.sh"; cat "$jobs/merge.sh"; exit 0; fi
    merge=$(sbatch --parsable --job-name=farm-merge --output="$jobs/merge-%j.log" "$jobs/merge.sh")
    echo "farm: merge job $merge"
    exit 0
fi
list=$(IFS=,; echo "${missing[*]}")
array_cmd=(sbatch --parsable --job-name=farm-render --array="$list" --cpus-per-task="$cpus" --output="$jobs/task-%A_%a.log" "$jobs/task.sh")
if [ $dry -eq 1 ]; then
    echo "${array_cmd[*]}"; cat "$jobs/task.sh"
    echo "sbatch --dependency=afterok:ARRAY --kill-on-invalid-dep=yes $jobs/merge.sh"; cat "$jobs/merge.sh"
    [ $retry -eq 1 ] || { echo "sbatch --dependency=afternotok:ARRAY $jobs/retry.sh"; cat "$jobs/retry.sh"; }
    exit 0
fi
array=$("${array_cmd[@]}")
merge=$(sbatch --parsable --job-name=farm-merge --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$jobs/merge-%j.log" "$jobs/merge.sh")
echo "farm: render array $array (units $list of $units), merge job $merge"
if [ $retry -eq 0 ]; then
    again=$(sbatch --parsable --job-name=farm-retry --dependency="afternotok:$array" --kill-on-invalid-dep=yes \
        --output="$jobs/retry-%j.log" "$jobs/retry.sh")
    echo "farm: retry job $again (runs only if a task fails)"
fi
