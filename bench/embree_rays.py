#!/usr/bin/env python3
"""Embree side of `bench rays`: trace the exact rays our BVH traced, on the exact triangles, and time it.

usage: embree_rays.py DIR [--repeat 3]
DIR holds what `bench rays` wrote: vertices.f32 (n×3), faces.i32 (m×3), and for each ray set NAME
(primary, incoherent) NAME.origins.f32, NAME.directions.f32 (k×3), NAME.ours_prim.i32 and
NAME.ours_t.f32 (our closest hits: triangle index or -1, distance). Embree 4 through embreex
(rtcIntersect1 per ray in a nogil C loop); 2 threads = Python threads over chunks.
Prints one JSON object: Mrays/s per set and thread count, and how often Embree and we agree.
"""
import argparse
import json
import math
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def best_seconds(fn, repeat):
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    d = a.dir
    V = np.fromfile(f"{d}/vertices.f32", np.float32).reshape(-1, 3)
    F = np.fromfile(f"{d}/faces.i32", np.int32).reshape(-1, 3)
    start = time.perf_counter()
    scene = rtcs.EmbreeScene(robust=True)
    TriangleMesh(scene, V, F)
    scene.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))  # forces the BVH build
    out = {"embree_build_s": round(time.perf_counter() - start, 4), "sets": {}}
    pool = ThreadPoolExecutor(2)
    for name in ("primary", "incoherent"):
        o = np.fromfile(f"{d}/{name}.origins.f32", np.float32).reshape(-1, 3)
        dr = np.fromfile(f"{d}/{name}.directions.f32", np.float32).reshape(-1, 3)
        ours_prim = np.fromfile(f"{d}/{name}.ours_prim.i32", np.int32)
        ours_t = np.fromfile(f"{d}/{name}.ours_t.f32", np.float32)
        n = len(o)
        step = max(1, math.ceil(n / 16))
        chunks = [(s, min(s + step, n)) for s in range(0, n, step)]

        def one():
            scene.run(o, dr)

        def two():
            list(pool.map(lambda se: scene.run(o[se[0]:se[1]], dr[se[0]:se[1]]), chunks))

        t1 = best_seconds(one, a.repeat)
        t2 = best_seconds(two, a.repeat)
        hits = scene.run(o, dr, output=1)
        prim = np.asarray(hits["primID"], np.int64)
        prim[np.asarray(hits["geomID"]) < 0] = -1
        tfar = np.asarray(hits["tfar"], np.float32)
        both_hit = (prim >= 0) & (ours_prim >= 0)
        same_side = (prim >= 0) == (ours_prim >= 0)
        rel = np.abs(tfar[both_hit] - ours_t[both_hit]) / np.maximum(np.abs(tfar[both_hit]), 1e-6)
        out["sets"][name] = {
            "rays": n,
            "embree_mrays_1thr": round(n / t1 / 1e6, 3),
            "embree_mrays_2thr": round(n / t2 / 1e6, 3),
            "hit_fraction": round(float((prim >= 0).mean()), 4),
            "agree_hit_or_miss": round(float(same_side.mean()), 6),
            "agree_distance_1e-4": round(float((rel < 1e-4).mean()) if both_hit.any() else 1.0, 6),
        }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
