#!/usr/bin/env python3
"""Import scene.usda into Blender (bpy) and render it with Cycles on the CPU at each spp of a sweep.

Origin: adapted from the project's shared peer scripts (shared/peers/run_cycles.py, 2026-11): the
USD import happens once, then every spp of the sweep renders in the same process.

usage: run_cycles.py SCENE_USDA --spp-list 1,2,4 [--res 256] [--threads 2] [--max-depth 8]
                     [--repeat 2] [--seed 0] --out-dir DIR
max-depth follows Mitsuba's convention (8 = up to 7 scattering events); Cycles bounces =
max_depth - 2 (Cycles' 0 bounces = direct lighting only).
Times: `bpy_import_s` and `usd_import_s` once; then a 1-spp warm-up render (`warmup_render_s`:
scene sync, BVH build, one sample); per spp, `render_s` is bpy.ops.render.render, which syncs the scene
and builds the BVH again on every render: with Persistent Data on, Blender 5.0.1 returned the previous
result in ~0.04 s whatever the sample count, so it stays off and the fixed cost is part of each time.
Blender's own log goes to stderr; stdout gets one JSON line. Writes DIR/cycles_<spp>.exr.
"""
import argparse
import json
import math
import os
import resource
import sys
import time


def cpu_s():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main():
    argv = sys.argv[1:]
    if '--' in argv:  # allow "blender -b -P run_cycles.py -- args"
        argv = argv[argv.index('--') + 1:]
    ap = argparse.ArgumentParser()
    ap.add_argument('scene')
    ap.add_argument('--spp-list', required=True)
    ap.add_argument('--out-dir', required=True)
    ap.add_argument('--res', type=int, default=256)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument('--out', default=None)
    ap.add_argument('--light-visible', type=int, default=1,
                    help='make imported lights visible to camera rays (importer leaves them hidden)')
    ap.add_argument('--distribution', default=None, choices=['GGX', 'MULTI_GGX'],
                    help='override the Principled BSDF microfacet model (importer leaves MULTI_GGX)')
    ap.add_argument('--seed', type=int, default=0)
    a = ap.parse_args(argv)
    load0 = open('/proc/loadavg').read().split()[:3]

    # Keep stdout for the JSON line only: send Blender's C-level prints to stderr.
    real_stdout = os.dup(1)
    os.dup2(2, 1)

    t = time.perf_counter()
    import bpy
    t_bpy = time.perf_counter() - t
    ver = bpy.app.version_string

    bpy.ops.wm.read_factory_settings(use_empty=True)  # no default cube/light/camera
    t = time.perf_counter()
    res = bpy.ops.wm.usd_import(filepath=os.path.abspath(a.scene))
    t_import = time.perf_counter() - t
    sc = bpy.context.scene

    # ---- what did the importer give us?
    report = {'import_result': list(res), 'camera_set_by_importer': sc.camera is not None,
              'resolution_after_import': [sc.render.resolution_x, sc.render.resolution_y]}
    cams = [o for o in sc.objects if o.type == 'CAMERA']
    if sc.camera is None and cams:
        sc.camera = cams[0]
    if sc.camera is not None:
        c = sc.camera.data
        report['camera'] = {'name': sc.camera.name, 'lens_mm': c.lens, 'sensor_mm': [c.sensor_width, c.sensor_height],
                            'fov_deg': round(math.degrees(c.angle), 4),
                            'location': [round(x, 4) for x in sc.camera.matrix_world.translation]}
    lights = []
    for o in sc.objects:
        if o.type == 'LIGHT':
            L = o.data
            lights.append({'name': o.name, 'type': L.type, 'energy_W': L.energy, 'color': list(L.color),
                           'size': [getattr(L, 'size', None), getattr(L, 'size_y', None)],
                           'normalize': getattr(L, 'normalize', None), 'exposure': getattr(L, 'exposure', None),
                           'location': [round(x, 4) for x in o.matrix_world.translation],
                           'visible_camera_after_import': o.visible_camera})
            if a.light_visible:
                o.visible_camera = True
    report['lights'] = lights
    mats = {}
    for m in bpy.data.materials:
        if not m.use_nodes:
            continue
        for n in m.node_tree.nodes:
            if n.type == 'BSDF_PRINCIPLED':
                report.setdefault('principled_distribution', n.distribution)
                if a.distribution:
                    n.distribution = a.distribution
                g = lambda k: (list(n.inputs[k].default_value)[:3] if hasattr(n.inputs[k].default_value, '__len__')
                               else n.inputs[k].default_value)
                mats[m.name] = {'base': [round(x, 4) for x in g('Base Color')], 'metallic': g('Metallic'),
                                'roughness': round(g('Roughness'), 4), 'ior': round(g('IOR'), 4),
                                'specular_tint': [round(x, 4) for x in g('Specular Tint')]}
    report['materials'] = mats
    report['mesh_triangles'] = sum(len(o.data.loop_triangles) if o.data.loop_triangles else
                                   sum(len(p.vertices) - 2 for p in o.data.polygons)
                                   for o in sc.objects if o.type == 'MESH')

    # ---- render settings
    sc.render.engine = 'CYCLES'
    cy = sc.cycles
    cy.device = 'CPU'
    cy.samples = 1
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = a.seed
    bounces = max(a.max_depth - 2, 0)
    cy.max_bounces = bounces
    cy.diffuse_bounces = bounces
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 8
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0  # Cycles default is 10 (biased); off for comparison
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = 'BOX'
    cy.filter_width = 1.0
    sc.render.threads_mode = 'FIXED'
    sc.render.threads = a.threads
    sc.render.resolution_x = a.res
    sc.render.resolution_y = a.res
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = False
    sc.view_settings.view_transform = 'Standard'
    sc.view_settings.look = 'None'
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    s = sc.render.image_settings
    s.file_format = 'OPEN_EXR'
    s.color_depth = '32'
    s.exr_codec = 'ZIP'

    t = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    t_warmup = time.perf_counter() - t
    os.makedirs(a.out_dir, exist_ok=True)
    rows = []
    for spp in [int(x) for x in a.spp_list.split(',')]:
        cy.samples = spp
        times, utils = [], []
        for _ in range(a.repeat):
            load = float(open('/proc/loadavg').read().split()[0])
            c, t = cpu_s(), time.perf_counter()
            bpy.ops.render.render(write_still=False)
            wall = time.perf_counter() - t
            times.append(round(wall, 4))
            utils.append(round((cpu_s() - c) / wall, 2))
        exr = os.path.join(a.out_dir, f'cycles_{spp}.exr')
        bpy.data.images['Render Result'].save_render(filepath=os.path.abspath(exr), scene=sc)
        rows.append({'spp': spp, 'render_s': times, 'cpu_utilisation': utils, 'loadavg_1min': load, 'exr': exr})

    result = {'renderer': 'cycles', 'tool': 'cycles', 'version': ver, 'python': sys.version.split()[0],
              'device': 'CPU', 'threads': sc.render.threads, 'res': a.res, 'bounces': bounces,
              'bpy_import_s': round(t_bpy, 3), 'load_s': round(t_import, 3), 'warmup_render_s': round(t_warmup, 3),
              'time_includes': 'bpy.ops.render.render: scene sync, BVH build, sampling, film (warmup_render_s, '
                               'a 1-spp render, bounds the fixed part); excludes bpy import and USD import',
              'peak_rss_MB': round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
              'usd_import_report': report, 'rows': rows}
    sys.stdout.flush()
    os.dup2(real_stdout, 1)
    print(json.dumps(result))
    sys.stdout.flush()
    os._exit(0)  # skip bpy's slow/noisy atexit teardown


if __name__ == '__main__':
    main()
