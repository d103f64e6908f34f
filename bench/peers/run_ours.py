#!/usr/bin/env python3
"""Ingest the peer scene with our `ingest`, then render it with our `render` at each spp of a sweep.

usage: run_ours.py SCENE_USDA --bin-dir TARGET/release --integrator wavefront|scalar --spp-list 1,2,4
                   [--res 256] [--max-depth 8] [--threads 2] [--repeat 2] [--seed 0] --out-dir DIR
max-depth follows Mitsuba's convention (8 = up to 7 scattering events, the last with emission only);
our --max-depth counts scattering events with next-event estimation, so we pass max_depth - 1.
Times: `ingest_s` (wall of the ingest process: compose, triangulate, BVH, pack) once; per spp,
`render_s` is the render time `render` prints (sampling and film; excludes process start-up, mapping
and validating the blob, and the EXR write). Writes DIR/ours_<integrator>_<spp>.exr; one JSON line.
"""
import argparse
import json
import os
import re
import subprocess
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('scene')
    ap.add_argument('--bin-dir', required=True)
    ap.add_argument('--integrator', default='wavefront', choices=['wavefront', 'scalar'])
    ap.add_argument('--spp-list', required=True)
    ap.add_argument('--res', type=int, default=256)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--name', default=None)
    ap.add_argument('--out-dir', required=True)
    a = ap.parse_args()
    name = a.name or f'ours_{a.integrator}'
    os.makedirs(a.out_dir, exist_ok=True)
    blob = os.path.join(a.out_dir, 'scene.blob')
    t = time.perf_counter()
    subprocess.run([os.path.join(a.bin_dir, 'ingest'), a.scene, '-o', blob, '-q'], check=True)
    ingest_s = time.perf_counter() - t

    rows = []
    for spp in [int(s) for s in a.spp_list.split(',')]:
        exr = os.path.join(a.out_dir, f'{name}_{spp}.exr')
        times, utils = [], []
        for _ in range(a.repeat):
            load = float(open('/proc/loadavg').read().split()[0])
            before = os.times()
            p = subprocess.run([os.path.join(a.bin_dir, 'render'), blob, '-o', exr, '--spp', str(spp),
                                '--res', f'{a.res}x{a.res}', '--threads', str(a.threads),
                                '--max-depth', str(a.max_depth - 1), '--seed', str(a.seed),
                                '--integrator', a.integrator], check=True, capture_output=True, text=True)
            after = os.times()
            m = re.search(r'load ([0-9.]+) s, render ([0-9.]+) s', p.stderr)
            if not m:
                raise SystemExit(f'render printed no timing line:\n{p.stderr}')
            wall = float(m.group(2))
            times.append(round(wall, 4))
            # Child CPU time covers the whole process; the render dominates it at any spp worth timing.
            cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
            utils.append(round(cpu / max(wall, 1e-9), 2))
        rows.append({'spp': spp, 'render_s': times, 'cpu_utilisation': utils, 'loadavg_1min': load, 'exr': exr})
    print(json.dumps({'renderer': name, 'tool': 'ours', 'integrator': a.integrator, 'threads': a.threads,
                      'res': a.res, 'max_depth': a.max_depth, 'ingest_s': round(ingest_s, 3),
                      'blob_bytes': os.path.getsize(blob),
                      'time_includes': 'render time printed by `render` (sampling, film); excludes process '
                                       'start-up, blob map+validate, EXR write; ingest reported separately',
                      'rows': rows}))


if __name__ == '__main__':
    main()
