#!/usr/bin/env python3
"""Render the Mitsuba version of the peer scene at each spp of a sweep and time each render.

Origin: adapted from the project's shared peer scripts (shared/peers/run_mitsuba.py, 2026-11):
one process renders every spp of the sweep after loading the scene once.

usage: run_mitsuba.py SCENE_XML --variant scalar_rgb|llvm_ad_rgb --spp-list 1,2,4 [--res 256]
                      [--max-depth 8] [--threads 2] [--repeat 2] [--seed 0] [--passes 1] --out-dir DIR
Times: `import_s` (import mitsuba), `load_s` (parse the XML, read the PLYs, build the BVH) once; per spp,
`render_s` is mi.render + dr.eval + sync (for llvm_ad_rgb the first repeat of each spp includes tracing
and LLVM compilation unless ~/.drjit already holds the kernel: `cold` in the row says which).
Writes DIR/<variant>_<spp>.exr and prints one JSON line.
"""
import argparse
import glob
import json
import os
import resource
import sys
import time


def cpu_s():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def newest_libllvm():
    # Dr.Jit 1.5's LLVM backend emits llvm.minimum/maximum, which libLLVM-14/15 cannot lower on x86
    # ("LLVM ERROR: Cannot select ... fminimum"): use libLLVM >= 16 (Debian: libllvm19).
    cands = (glob.glob('/usr/lib/x86_64-linux-gnu/libLLVM.so.1[6-9]*')
             + glob.glob('/usr/lib/x86_64-linux-gnu/libLLVM.so.2[0-9]*')
             + glob.glob('/usr/lib/x86_64-linux-gnu/libLLVM-1[6-9].so.1')
             + glob.glob('/usr/lib/x86_64-linux-gnu/libLLVM-2[0-9].so.1'))
    return sorted(cands)[-1] if cands else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('scene')
    ap.add_argument('--variant', default='scalar_rgb')
    ap.add_argument('--spp-list', required=True)
    ap.add_argument('--res', type=int, default=256)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--passes', type=int, default=1,
                    help='average this many renders of spp samples (seeds seed..seed+passes-1): a high-spp '
                         'reference without a res*spp-lane JIT wavefront that would not fit in memory')
    ap.add_argument('--name', default=None, help='renderer name in the JSON (default mitsuba_<variant>)')
    ap.add_argument('--out-dir', required=True)
    a = ap.parse_args()
    name = a.name or f'mitsuba_{a.variant}'
    # Mitsuba logs warnings to stdout: keep stdout for the JSON line only.
    real_stdout = os.dup(1)
    os.dup2(2, 1)
    os.makedirs(a.out_dir, exist_ok=True)
    if a.variant.startswith('llvm') and 'DRJIT_LIBLLVM_PATH' not in os.environ and newest_libllvm():
        os.environ['DRJIT_LIBLLVM_PATH'] = newest_libllvm()
    t = time.perf_counter()
    import drjit as dr
    import mitsuba as mi
    mi.set_variant(a.variant)
    dr.set_thread_count(a.threads)
    jit = a.variant.startswith(('llvm', 'cuda'))
    if jit:
        dr.set_flag(dr.JitFlag.KernelHistory, True)
    t_import = time.perf_counter() - t
    t = time.perf_counter()
    scene = mi.load_file(a.scene, spp=a.spp_list.split(',')[0], res=a.res, max_depth=a.max_depth)
    t_load = time.perf_counter() - t
    if jit:
        dr.kernel_history()  # drop scene-load kernels

    rows = []
    for spp in [int(s) for s in a.spp_list.split(',')]:
        times, utils, compiled = [], [], []
        img = None
        for _ in range(a.repeat):
            load = float(open('/proc/loadavg').read().split()[0])
            c, t = cpu_s(), time.perf_counter()
            img = None
            for p in range(a.passes):
                one = mi.render(scene, spp=spp, seed=a.seed + p)
                img = one if img is None else img + one
                dr.eval(img)
            img = img / a.passes
            dr.eval(img)
            dr.sync_thread()
            wall = time.perf_counter() - t
            times.append(round(wall, 4))
            utils.append(round((cpu_s() - c) / wall, 2))
            if jit:
                h = dr.kernel_history()
                compiled.append(round(sum(k.get('backend_time', 0) for k in h if not k.get('cache_hit')), 1))
        exr = os.path.join(a.out_dir, f'{name}_{spp * a.passes}.exr')
        mi.Bitmap(img).write(exr)
        row = {'spp': spp * a.passes, 'render_s': times, 'cpu_utilisation': utils, 'loadavg_1min': load, 'exr': exr}
        if jit:
            row['llvm_compile_ms'] = compiled  # backend compile time per repeat (0: memory/disk cache hit)
        rows.append(row)
    sys.stdout.flush()
    os.dup2(real_stdout, 1)
    print(json.dumps({'renderer': name, 'tool': 'mitsuba', 'version': mi.__version__, 'variant': a.variant,
                      'threads': dr.thread_count(), 'res': a.res, 'max_depth': a.max_depth,
                      'import_s': round(t_import, 3), 'load_s': round(t_load, 3),
                      'libllvm': os.environ.get('DRJIT_LIBLLVM_PATH') if jit else None,
                      'time_includes': 'mi.render + dr.eval (sampling, film; llvm: JIT trace+compile on a cold cache); '
                                       'excludes import, XML/PLY load and BVH build',
                      'peak_rss_MB': round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
                      'rows': rows}))


if __name__ == '__main__':
    main()
