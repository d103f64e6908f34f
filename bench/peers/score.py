#!/usr/bin/env python3
"""Score the peer sweeps against a high-spp reference and write peers.json.

Origin: the error measures follow the project's shared peer scripts (shared/peers/compare.py, 2026-11).

usage: score.py --reference REF.exr --reference-renderer NAME --reference-spp N
                [--agree NAME=EXR@SPP ...] [--own-reference NAME=EXR ...] SWEEP.json ... --out peers.json
SWEEP.json: the JSON lines of run_ours.py / run_cycles.py / run_mitsuba.py; rows of files with the same
renderer name are merged. Every image is compared with the reference over the pixels where the
reference does not see the light itself (max channel <= 5): RMSE (linear), plus the all-pixel RMSE.
--agree: the high-spp images of each renderer, compared pairwise: RMSE, the RMSE expected from their
noise alone, the mean ratio per channel and per region (a bias shows as a ratio off 1 in a region).
--own-reference NAME=EXR: that renderer's own high-spp image, to estimate its per-sample noise.
"""
import argparse
import json
import os

import numpy as np

LIGHT_THRESHOLD = 5.0
# Pixel boxes (y0, y1, x0, x1) in a 512x512 frame of make_scene.py's camera, scaled to the resolution.
REGIONS = {'back_wall': (150, 250, 200, 300), 'red_wall': (200, 300, 20, 80),
           'green_wall': (200, 300, 430, 490), 'floor': (470, 500, 200, 300),
           'ceiling': (5, 35, 200, 300), 'sphere': (320, 400, 140, 220), 'metal_box': (360, 440, 300, 380)}


def load(path):
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def rmse(a, b, mask):
    return float(np.sqrt(((a - b) ** 2)[mask].mean()))


def agreement(a, b, mask):
    ra = {}
    f = a.shape[0] / 512.0
    for n, box in REGIONS.items():
        y0, y1, x0, x1 = (int(round(v * f)) for v in box)
        ma = a[y0:y1, x0:x1].reshape(-1, 3).mean(0)
        mb = b[y0:y1, x0:x1].reshape(-1, 3).mean(0)
        ra[n] = (ma / np.maximum(mb, 1e-9)).round(4).tolist()
    return {'rmse': round(rmse(a, b, mask), 6),
            'mean_ratio_rgb': (a[mask].mean(0) / b[mask].mean(0)).round(4).tolist(),
            'region_ratio_rgb': ra}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('sweeps', nargs='+')
    ap.add_argument('--reference', required=True)
    ap.add_argument('--reference-renderer', required=True)
    ap.add_argument('--reference-spp', type=int, required=True)
    ap.add_argument('--agree', action='append', default=[], help='NAME=EXR@SPP')
    ap.add_argument('--own-reference', action='append', default=[], help='NAME=EXR')
    ap.add_argument('--scene', default=None, help="make_scene.py's JSON line")
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    ref = load(a.reference)
    mask = ref.max(-1) <= LIGHT_THRESHOLD
    own = {k: load(v) for k, v in (x.split('=', 1) for x in a.own_reference)}

    renderers = {}
    for path in a.sweeps:
        for line in open(path):
            if not line.strip():
                continue
            run = json.loads(line)
            name = run.pop('renderer')
            entry = renderers.setdefault(name, {'name': name, 'runs': [], 'points': []})
            rows = run.pop('rows')
            entry['runs'].append(run)
            for row in rows:
                img = load(row['exr'])
                # CPU-seconds (wall × utilisation) are the work done, less sensitive to other processes
                # taking the cores than wall seconds; best of the repeats for both.
                cpu = [w * u for w, u in zip(row['render_s'], row['cpu_utilisation'])]
                point = {'spp': row['spp'], 'seconds': min(row['render_s']), 'seconds_all': row['render_s'],
                         'cpu_seconds': round(min(cpu), 4),
                         'cpu_utilisation': row['cpu_utilisation'], 'loadavg_1min': row['loadavg_1min'],
                         'rmse': round(rmse(img, ref, mask), 6),
                         'rmse_all_pixels': round(float(np.sqrt(((img - ref) ** 2).mean())), 6)}
                for k in ('llvm_compile_ms',):
                    if k in row:
                        point[k] = row[k]
                if name in own:
                    point['rmse_vs_own_reference'] = round(rmse(img, own[name], mask), 6)
                entry['points'].append(point)
    for e in renderers.values():
        e['points'].sort(key=lambda p: p['spp'])

    # Per-sample noise of a renderer from its top sweep image against its own N-spp reference:
    # rmse^2 = s^2/n + s^2/N, so s^2 = rmse^2 / (1/n + 1/N); its reference then has noise s/sqrt(N).
    sigma1 = {}
    for x in a.agree:
        name, rest = x.split('=', 1)
        _, spp = rest.rsplit('@', 1)
        pts = [p for p in renderers.get(name.replace('reference_', ''), {}).get('points', [])
               if 'rmse_vs_own_reference' in p]
        if pts:
            top = pts[-1]
            sigma1[name] = top['rmse_vs_own_reference'] / np.sqrt(1 / top['spp'] + 1 / int(spp))
    images = []
    for x in a.agree:
        name, rest = x.split('=', 1)
        exr, spp = rest.rsplit('@', 1)
        images.append((name, int(spp), load(exr)))
    pairs = []
    for i in range(len(images)):
        for j in range(i + 1, len(images)):
            (na, sa, ia), (nb, sb, ib) = images[i], images[j]
            p = {'a': na, 'spp_a': sa, 'b': nb, 'spp_b': sb, **agreement(ia, ib, mask)}
            if na in sigma1 and nb in sigma1:
                p['rmse_expected_from_noise'] = round(float(np.sqrt(sigma1[na] ** 2 / sa + sigma1[nb] ** 2 / sb)), 6)
            pairs.append(p)

    out = {'reference': {'renderer': a.reference_renderer, 'spp': a.reference_spp, 'exr': a.reference,
                         'mean_rgb': ref[mask].mean(0).round(5).tolist(), 'light_pixels_masked': int((~mask).sum()),
                         'resolution': [ref.shape[1], ref.shape[0]]},
           'scene': json.loads(a.scene) if a.scene else None,
           'nproc': os.cpu_count(),
           'reference_agreement': pairs,
           'renderers': list(renderers.values())}
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, 'w') as fh:
        json.dump(out, fh, indent=1)
    print(json.dumps({'tool': 'score', 'out': a.out, 'renderers': list(renderers)}))


if __name__ == '__main__':
    main()
