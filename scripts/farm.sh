#!/usr/bin/env bash
# Renders one blob, or a frame sequence, on a Slurm farm: a job array of work units (frames,
# tiles or sample slices, one task each), a merge array that depends on it (afterok; one task per
# frame that was split), and a retry job that runs only if a task failed (afternotok) and
# resubmits the missing units once, with their own merges.
#
#   scripts/farm.sh [--frames A-B[xS]] [--tiles N | --samples K] [--cpus C] [--render BIN] [--dry-run] BLOB -o OUT.exr [RENDER OPTION...]
#
#   --frames R    a sequence: BLOB and OUT are patterns (shot.####.blob, beauty.%04d.exr; named by
#                 `render frames`, as render and ingest name them); one unit per frame, times tiles
#                 or slices. An unsplit frame renders straight to its OUT; a split one is merged.
#   --tiles N     N bands of rows (render --tile I/N); the merged EXR equals a single render byte for byte
#   --samples K   K sample slices of --spp (render --sample-range A..B); equal within float rounding
#   --cpus C      --cpus-per-task and render --threads (default 1)
#   --render BIN  the render binary every node runs (default: target/release/render beside this script)
#   --dry-run     print the units and the sbatch scripts and commands instead of submitting
#
# Parts go to OUT.parts/ (per frame; shared storage, as the blob and OUT must be): each task
# writes its part (or frame) atomically, so a task that dies leaves nothing under its final name,
# and running the same command again submits only the units whose part or frame is missing (a
# frame whose OUT exists is done). Prints the job ids. Any RENDER OPTION (--spp, --res, --seed,
# --crop, ...) is passed to every unit.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tiles=1 samples=1 cpus=1 dry=0 retry=0 frames=""
render_bin=$here/../target/release/render
blob="" out="" opts=()
while [ $# -gt 0 ]; do
    case "$1" in
        --frames) frames=$2; shift 2 ;;
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
[ -n "$blob" ] && [ -n "$out" ] || fail "usage: $0 [--frames A-B[xS]] [--tiles N | --samples K] [--cpus C] [--render BIN] [--dry-run] BLOB -o OUT.exr [RENDER OPTION...]"
[ "$tiles" -ge 1 ] && [ "$samples" -ge 1 ] || fail "--tiles and --samples must be at least 1"
[ "$tiles" -eq 1 ] || [ "$samples" -eq 1 ] || fail "split by --tiles or by --samples, not both"
[ -x "$render_bin" ] || fail "no render binary $render_bin (cargo build --release -p render, or --render BIN)"
abs() { (cd "$(dirname "$1")" && echo "$(pwd)/$(basename "$1")"); }
blob=$(abs "$blob") out=$(abs "$out") render_bin=$(abs "$render_bin")
spp=16
for ((i = 0; i < ${#opts[@]}; i++)); do [ "${opts[$i]}" = --spp ] && spp=${opts[$((i + 1))]}; done
[ "$samples" -le "$spp" ] || fail "--samples $samples is more than --spp $spp"

# The frames: (number, blob, output) per line; one frame of the literal paths without --frames.
frame_no=() frame_blob=() frame_out=()
if [ -n "$frames" ]; then
    listing=$("$render_bin" frames --frames "$frames" "$blob" "$out" 2>&1) || fail "$listing"
    while IFS=$'\t' read -r f b o; do frame_no+=("$f"); frame_blob+=("$b"); frame_out+=("$o"); done <<< "$listing"
else
    frame_no=(0) frame_blob=("$blob") frame_out=("$out")
fi
nframes=${#frame_no[@]}
absent=()
for ((k = 0; k < nframes; k++)); do [ -f "${frame_blob[$k]}" ] || absent+=("frame ${frame_no[$k]}: ${frame_blob[$k]}"); done
if [ ${#absent[@]} -gt 0 ]; then
    if [ -n "$frames" ]; then fail "${#absent[@]} of $nframes frames have no blob: $(IFS=,; echo "${absent[*]}")"; fi
    fail "no blob $blob"
fi

parts=$out.parts jobs=$out.parts/jobs
mkdir -p "$jobs"
per=$((tiles * samples))
units=$((nframes * per))
# Whether a frame's units write parts that are merged (always without --frames, as before).
split=0; { [ "$per" -gt 1 ] || [ -z "$frames" ]; } && split=1
frame_parts() { if [ -n "$frames" ]; then echo "${frame_out[$1]}.parts"; else echo "$parts"; fi; }
# The render options of unit U of a frame: its tile, or its slice of the samples (as even as they divide).
unit_args() {
    if [ "$tiles" -gt 1 ]; then echo "--tile $1/$tiles"; fi
    if [ "$samples" -gt 1 ]; then echo "--sample-range $(($1 * spp / samples))..$((($1 + 1) * spp / samples))"; fi
    if [ "$per" -eq 1 ] && [ $split -eq 1 ]; then echo "--tile 0/1"; fi
}
# Task I is unit I % per of frame I / per; it writes its part, or (unsplit) the frame itself.
task_out() {
    local k=$(($1 / per)) u=$(($1 % per))
    if [ $split -eq 1 ]; then echo "$(frame_parts $k)/part-$u.exr"; else echo "${frame_out[$k]}"; fi
}
missing=() merges=()
for ((k = 0; k < nframes; k++)); do
    if [ -n "$frames" ] && [ -s "${frame_out[$k]}" ]; then continue; fi
    [ $split -eq 1 ] && merges+=("$k")
    for ((u = 0; u < per; u++)); do [ -s "$(task_out $((k * per + u)))" ] || missing+=("$((k * per + u))"); done
    [ -n "$frames" ] && [ $split -eq 1 ] && mkdir -p "$(frame_parts $k)"
done
quoted=$(printf ' %q' "${opts[@]}")
if [ -n "$frames" ]; then
    echo "farm: $nframes frames ($frames) x $per units per frame"
    for ((k = 0; k < nframes; k++)); do
        state=todo; [ -s "${frame_out[$k]}" ] && state=done
        echo "farm: frame ${frame_no[$k]} ($state): ${frame_blob[$k]} -> ${frame_out[$k]}"
    done
fi

{
    echo '#!/usr/bin/env bash'
    echo '# One work unit: $SLURM_ARRAY_TASK_ID. render writes its output atomically (temporary + rename).'
    echo 'set -euo pipefail'
    echo 'i=$SLURM_ARRAY_TASK_ID'
    echo 'case $i in'
    for ((i = 0; i < units; i++)); do
        k=$((i / per))
        if [ -n "$frames" ]; then
            echo "    $i) unit=\"$(unit_args $((i % per)))\" blob=$(printf %q "${frame_blob[$k]}") out=$(printf %q "$(task_out $i)") ;;"
        else
            echo "    $i) unit=\"$(unit_args $i)\" ;;"
        fi
    done
    echo 'esac'
    if [ -n "$frames" ]; then
        echo "exec $(printf %q "$render_bin") \"\$blob\" -o \"\$out\" --threads $cpus$quoted \$unit"
    else
        echo "exec $(printf %q "$render_bin") $(printf %q "$blob") -o $(printf %q "$parts")/part-\$i.exr --threads $cpus$quoted \$unit"
    fi
} > "$jobs/task.sh"
{
    echo '#!/usr/bin/env bash'
    echo '# Merges frame $SLURM_ARRAY_TASK_ID of the sequence from its parts.'
    echo 'set -euo pipefail'
    echo 'case $SLURM_ARRAY_TASK_ID in'
    for ((k = 0; k < nframes; k++)); do
        list=""; for ((u = 0; u < per; u++)); do list+=" $(printf %q "$(frame_parts $k)/part-$u.exr")"; done
        echo "    $k) parts=($list); blob=$(printf %q "${frame_blob[$k]}"); out=$(printf %q "${frame_out[$k]}") ;;"
    done
    echo 'esac'
    echo "exec $(printf %q "$render_bin") merge --blob \"\$blob\" \"\${parts[@]}\" -o \"\$out\""
} > "$jobs/merge.sh"
args=$(printf ' %q' --tiles "$tiles" --samples "$samples" --cpus "$cpus" --render "$render_bin")
[ -n "$frames" ] && args+=$(printf ' %q' --frames "$frames")
args+=$(printf ' %q' "$blob" -o "$out" "${opts[@]}")
cat > "$jobs/retry.sh" <<RETRY
#!/usr/bin/env bash
# A task of the array failed: resubmit the units whose part or frame is missing, once.
set -euo pipefail
exec bash $(printf %q "$here/farm.sh") --retry$args
RETRY

merge_list=$(IFS=,; echo "${merges[*]}")
if [ ${#missing[@]} -eq 0 ]; then
    if [ ${#merges[@]} -eq 0 ]; then echo "farm: all $nframes frames are done"; exit 0; fi
    echo "farm: all parts of frames ${merge_list} are in place; merging"
    merge_cmd=(sbatch --parsable --job-name=farm-merge --array="$merge_list" --output="$jobs/merge-%A_%a.log" "$jobs/merge.sh")
    if [ $dry -eq 1 ]; then echo "${merge_cmd[*]}"; cat "$jobs/merge.sh"; exit 0; fi
    merge=$("${merge_cmd[@]}")
    echo "farm: merge job $merge"
    exit 0
fi
list=$(IFS=,; echo "${missing[*]}")
array_cmd=(sbatch --parsable --job-name=farm-render --array="$list" --cpus-per-task="$cpus" --output="$jobs/task-%A_%a.log" "$jobs/task.sh")
if [ $dry -eq 1 ]; then
    echo "farm: units $list of $units"
    echo "${array_cmd[*]}"; cat "$jobs/task.sh"
    if [ ${#merges[@]} -gt 0 ]; then
        echo "sbatch --array=$merge_list --dependency=afterok:ARRAY --kill-on-invalid-dep=yes $jobs/merge.sh"; cat "$jobs/merge.sh"
    fi
    [ $retry -eq 1 ] || { echo "sbatch --dependency=afternotok:ARRAY $jobs/retry.sh"; cat "$jobs/retry.sh"; }
    exit 0
fi
array=$("${array_cmd[@]}")
merge=none
if [ ${#merges[@]} -gt 0 ]; then
    merge=$(sbatch --parsable --job-name=farm-merge --array="$merge_list" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
        --output="$jobs/merge-%A_%a.log" "$jobs/merge.sh")
fi
echo "farm: render array $array (units $list of $units), merge job $merge"
if [ $retry -eq 0 ]; then
    again=$(sbatch --parsable --job-name=farm-retry --dependency="afternotok:$array" --kill-on-invalid-dep=yes \
        --output="$jobs/retry-%j.log" "$jobs/retry.sh")
    echo "farm: retry job $again (runs only if a task fails)"
fi
