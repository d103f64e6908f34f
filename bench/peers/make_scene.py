#!/usr/bin/env python3
"""Build the peer-benchmark test scene two ways (USD for us and Cycles, PLY + XML for Mitsuba 3).

Origin: the project's shared peer scripts (shared/peers/make_scene.py, 2026-11); OBJ output dropped.

Cornell-box-like room (2 x 2 x 2 m, Y-up, metersPerUnit=1), white floor/ceiling/back,
red left wall, green right wall, one 0.5 x 0.5 m UsdLux RectLight under the ceiling,
an icosphere (level 6 -> 81,920 triangles, smooth vertex normals, diffuse) and a
small rotated metal box (rough GGX conductor, flat normals).

usage: make_scene.py [OUTDIR] [--subdiv 6] [--res 512] [--spp 64]
Prints one JSON line describing what was written.
"""
import argparse
import json
import math
import os
import time

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdRender, Vt

# ----------------------------------------------------------------------------- parameters
WHITE = (0.73, 0.73, 0.73)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
SPHERE_COL = (0.35, 0.5, 0.8)  # pale blue diffuse
METAL_COL = (0.9, 0.75, 0.45)  # gold-ish F0
METAL_ROUGH = 0.3  # UsdPreviewSurface roughness (GGX alpha = roughness^2 = 0.09)

LIGHT_SIZE = 0.5
LIGHT_Y = 1.998
LIGHT_INTENSITY = 15.0
LIGHT_COLOR = (1.0, 0.9, 0.75)  # radiance = intensity * 2^exposure * color (normalize=false)

CAM_POS = (0.0, 1.0, 3.85)
FOCAL = 35.0
APERTURE = 24.0  # square sensor -> fov = 2 atan(12/35) = 37.85 deg


# ----------------------------------------------------------------------------- geometry
def quad(p0, p1, p2, p3):
    """Quad p0..p3 counter-clockwise seen from the front -> 2 triangles."""
    v = np.array([p0, p1, p2, p3], dtype=np.float64)
    n = np.cross(v[1] - v[0], v[2] - v[0])
    n /= np.linalg.norm(n)
    f = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)
    return v, np.tile(n, (4, 1)), f


def merge(parts):
    vs, ns, fs, off = [], [], [], 0
    for v, n, f in parts:
        vs.append(v)
        ns.append(n)
        fs.append(f + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(ns), np.concatenate(fs)


def room():
    floor = quad((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))  # normal +y
    ceil = quad((-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1))  # normal -y
    back = quad((-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1))  # normal +z
    left = quad((-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1))  # normal +x
    right = quad((1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1))  # normal -x
    return merge([floor, ceil, back]), left, right


def icosphere(level, center, radius):
    t = (1.0 + 5 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
             (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [np.array(v, float) / np.linalg.norm(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        cache, nf = {}, []

        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[k] = len(verts) - 1
            return cache[k]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    n = np.array(verts)
    return n * radius + np.array(center), n.copy(), np.array(faces, np.int32)


def box(center, size, rot_y_deg):
    sx, sy, sz = (s / 2 for s in size)
    c = [(-sx, -sy, -sz), (sx, -sy, -sz), (sx, sy, -sz), (-sx, sy, -sz),
         (-sx, -sy, sz), (sx, -sy, sz), (sx, sy, sz), (-sx, sy, sz)]
    faces = [(4, 5, 6, 7), (1, 0, 3, 2), (5, 1, 2, 6), (0, 4, 7, 3), (7, 6, 2, 3), (0, 1, 5, 4)]
    parts = [quad(*[c[i] for i in f]) for f in faces]
    v, n, f = merge(parts)
    a = math.radians(rot_y_deg)
    R = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    return v @ R.T + np.array(center), n @ R.T, f


# ----------------------------------------------------------------------------- writers
def write_ply(path, v, n, f):
    vert = np.empty(len(v), dtype=[('x', '<f4'), ('y', '<f4'), ('z', '<f4'),
                                   ('nx', '<f4'), ('ny', '<f4'), ('nz', '<f4')])
    vert['x'], vert['y'], vert['z'] = v.T
    vert['nx'], vert['ny'], vert['nz'] = n.T
    face = np.empty(len(f), dtype=[('n', 'u1'), ('i', '<i4', (3,))])
    face['n'] = 3
    face['i'] = f
    hdr = ("ply\nformat binary_little_endian 1.0\n"
           f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
           "property float nx\nproperty float ny\nproperty float nz\n"
           f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, 'wb') as fh:
        fh.write(hdr.encode())
        fh.write(vert.tobytes())
        fh.write(face.tobytes())


LAMBERT_MODE = 'ior1'


def usd_material(stage, name, diffuse, metallic=0.0, roughness=1.0, lambert=True):
    mat = UsdShade.Material.Define(stage, f'/World/Looks/{name}')
    sh = UsdShade.Shader.Define(stage, f'/World/Looks/{name}/PreviewSurface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    sh.CreateInput('metallic', Sdf.ValueTypeNames.Float).Set(float(metallic))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(float(roughness))
    if lambert and LAMBERT_MODE == 'specwf0':
        # Specular workflow with a black specularColor: F0 = 0, but per the UsdPreviewSurface
        # spec the edge colour stays white, and Blender maps it to Specular Tint = 0 with
        # white grazing reflection -> NOT a pure Lambertian in Cycles.
        sh.CreateInput('useSpecularWorkflow', Sdf.ValueTypeNames.Int).Set(1)
        sh.CreateInput('specularColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    elif lambert and LAMBERT_MODE == 'ior1':
        # Metallic workflow with ior = 1: no dielectric Fresnel at any angle (Blender maps it
        # to Principled IOR = 1.0) -> pure Lambertian, matching Mitsuba's 'diffuse'.
        sh.CreateInput('ior', Sdf.ValueTypeNames.Float).Set(1.0)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def usd_mesh(stage, name, v, n, f, mat, smooth):
    m = UsdGeom.Mesh.Define(stage, f'/World/Geom/{name}')
    m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(v.astype(np.float32)))
    m.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(f), 3, np.int32)))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(f.reshape(-1).astype(np.int32)))
    m.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(n.astype(np.float32)))
    m.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    # Important: the USD default is catmullClark, for which authored normals are ignored.
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    m.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    m.CreateDoubleSidedAttr(True)
    lo, hi = v.min(0), v.max(0)
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*lo), Gf.Vec3f(*hi)]))
    UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
    return m


def metal_bsdf_xml(kind):
    if kind == 'principled':
        return (f'<bsdf type="principled"><rgb name="base_color" value="{METAL_COL[0]} {METAL_COL[1]} {METAL_COL[2]}"/>'
                f'<float name="metallic" value="1"/><float name="roughness" value="{METAL_ROUGH}"/></bsdf>')
    return ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/>'
            f'<float name="alpha" value="{METAL_ROUGH**2:.6g}"/><string name="material" value="none"/>'
            f'<rgb name="specular_reflectance" value="{METAL_COL[0]} {METAL_COL[1]} {METAL_COL[2]}"/></bsdf>')


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('outdir', nargs='?', default='scene')
    ap.add_argument('--subdiv', type=int, default=6)
    ap.add_argument('--res', type=int, default=512)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--lambert', choices=['ior1', 'specwf0', 'default'], default='ior1',
                    help='how the diffuse UsdPreviewSurfaces ask for "no specular"')
    ap.add_argument('--mitsuba-metal', choices=['conductor', 'principled'], default='conductor',
                    help="Mitsuba's metal box: roughconductor with a constant reflectance (no Fresnel), or "
                         "principled metallic = 1 (Schlick from base_color to white, as UsdPreviewSurface)")
    ap.add_argument('--mitsuba-light', choices=['null', 'black'], default='null',
                    help="BSDF of Mitsuba's emitter rectangle")
    ap.add_argument('--light-parent', choices=['xform', 'typeless'], default='xform',
                    help='typeless reproduces the Blender light-placement bug')
    a = ap.parse_args()
    global LAMBERT_MODE
    LAMBERT_MODE = a.lambert
    t0 = time.perf_counter()
    out = os.path.abspath(a.outdir)
    os.makedirs(os.path.join(out, 'meshes'), exist_ok=True)

    (wv, wn, wf), left, right = room()
    sph = icosphere(a.subdiv, (-0.4, 0.4, -0.25), 0.4)
    bx = box((0.45, 0.3, 0.3), (0.45, 0.6, 0.45), -20.0)
    meshes = {  # name: (geom, usd material kwargs, mitsuba bsdf xml, smooth)
        'WhiteWalls': ((wv, wn, wf), dict(diffuse=WHITE),
                       f'<bsdf type="diffuse"><rgb name="reflectance" value="{WHITE[0]} {WHITE[1]} {WHITE[2]}"/></bsdf>'),
        'RedWall': (left, dict(diffuse=RED),
                    f'<bsdf type="diffuse"><rgb name="reflectance" value="{RED[0]} {RED[1]} {RED[2]}"/></bsdf>'),
        'GreenWall': (right, dict(diffuse=GREEN),
                      f'<bsdf type="diffuse"><rgb name="reflectance" value="{GREEN[0]} {GREEN[1]} {GREEN[2]}"/></bsdf>'),
        'Sphere': (sph, dict(diffuse=SPHERE_COL),
                   f'<bsdf type="diffuse"><rgb name="reflectance" value="{SPHERE_COL[0]} {SPHERE_COL[1]} {SPHERE_COL[2]}"/></bsdf>'),
        'MetalBox': (bx, dict(diffuse=METAL_COL, metallic=1.0, roughness=METAL_ROUGH, lambert=False),
                     metal_bsdf_xml(a.mitsuba_metal)),
    }

    # ---------------- USD
    usd_path = os.path.join(out, 'scene.usda')
    stage = Usd.Stage.CreateNew(usd_path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, '/World')
    stage.SetDefaultPrim(world.GetPrim())
    UsdGeom.Scope.Define(stage, '/World/Looks')
    UsdGeom.Scope.Define(stage, '/World/Geom')
    ntris = 0
    for name, ((v, n, f), mk, _) in meshes.items():
        usd_mesh(stage, name, v, n, f, usd_material(stage, name + 'Mat', **mk), smooth=(name == 'Sphere'))
        ntris += len(f)

    if a.light_parent == 'xform':
        # Blender 5.0's importer drops the Y-up->Z-up root rotation for a light whose parent is a
        # typeless prim (what RectLight.Define creates implicitly), so author an explicit Xform.
        UsdGeom.Xform.Define(stage, '/World/Lights')
    light = UsdLux.RectLight.Define(stage, '/World/Lights/CeilingLight')
    light.CreateWidthAttr(LIGHT_SIZE)
    light.CreateHeightAttr(LIGHT_SIZE)
    light.CreateIntensityAttr(LIGHT_INTENSITY)
    light.CreateExposureAttr(0.0)
    light.CreateColorAttr(Gf.Vec3f(*LIGHT_COLOR))
    light.CreateNormalizeAttr(False)
    lx = UsdGeom.Xformable(light)
    lx.AddTranslateOp().Set(Gf.Vec3d(0, LIGHT_Y, 0))
    lx.AddRotateXOp().Set(-90.0)  # RectLight emits along local -Z; rotate so it points down (-Y)

    cam = UsdGeom.Camera.Define(stage, '/World/Camera')
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.CreateFocalLengthAttr(FOCAL)
    cam.CreateHorizontalApertureAttr(APERTURE)
    cam.CreateVerticalApertureAttr(APERTURE)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 100.0))
    UsdGeom.Xformable(cam).AddTranslateOp().Set(Gf.Vec3d(*CAM_POS))  # looks down -Z

    rs = UsdRender.Settings.Define(stage, '/Render/Settings')
    rs.CreateResolutionAttr(Gf.Vec2i(a.res, a.res))
    rs.CreateCameraRel().SetTargets([cam.GetPath()])
    stage.GetRootLayer().customLayerData = {'peers': {'spp': a.spp, 'maxDepth': a.max_depth}}
    stage.GetRootLayer().Save()

    # ---------------- PLY
    for name, ((v, n, f), _, _) in meshes.items():
        write_ply(os.path.join(out, 'meshes', name + '.ply'), v, n, f)

    # ---------------- Mitsuba XML (spp/res/max_depth overridable at load time)
    fov = math.degrees(2 * math.atan(APERTURE / 2 / FOCAL))
    L = [LIGHT_INTENSITY * c for c in LIGHT_COLOR]
    shapes = []
    for name, ((v, n, f), _, bsdf) in meshes.items():
        shapes.append(f'  <shape type="ply" id="{name}">\n    <string name="filename" value="meshes/{name}.ply"/>\n'
                      f'    <boolean name="face_normals" value="false"/>\n    {bsdf}\n  </shape>')
    # USD lights are not geometry: Cycles' area light neither blocks nor reflects. A 'null' BSDF
    # makes Mitsuba's emitter rectangle pass-through too (a black diffuse one absorbs ~0.5-1%
    # of the indirect light and darkens the image by that much).
    light_bsdf = ('<bsdf type="null"/>' if a.mitsuba_light == 'null'
                  else '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>')
    xml = f'''<scene version="3.0.0">
  <default name="spp" value="{a.spp}"/>
  <default name="res" value="{a.res}"/>
  <default name="max_depth" value="{a.max_depth}"/>
  <integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>
  <sensor type="perspective">
    <string name="fov_axis" value="x"/>
    <float name="fov" value="{fov:.6f}"/>
    <float name="near_clip" value="0.01"/>
    <float name="far_clip" value="100"/>
    <transform name="to_world">
      <lookat origin="{CAM_POS[0]}, {CAM_POS[1]}, {CAM_POS[2]}" target="{CAM_POS[0]}, {CAM_POS[1]}, {CAM_POS[2]-1}" up="0, 1, 0"/>
    </transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="$res"/>
      <integer name="height" value="$res"/>
      <rfilter type="box"/>
      <string name="pixel_format" value="rgb"/>
    </film>
  </sensor>
{chr(10).join(shapes)}
  <shape type="rectangle" id="CeilingLight">
    <transform name="to_world">
      <scale value="{LIGHT_SIZE/2}"/>
      <rotate x="1" angle="90"/>
      <translate value="0, {LIGHT_Y}, 0"/>
    </transform>
    {light_bsdf}
    <emitter type="area"><rgb name="radiance" value="{L[0]:.6g} {L[1]:.6g} {L[2]:.6g}"/></emitter>
  </shape>
</scene>
'''
    xml_path = os.path.join(out, 'scene_mitsuba.xml')
    with open(xml_path, 'w') as fh:
        fh.write(xml)
    print(json.dumps({'tool': 'make_scene', 'usd': usd_path, 'mitsuba_xml': xml_path,
                      'triangles': int(ntris), 'sphere_triangles': int(len(sph[2])),
                      'fov_deg': fov, 'light_radiance_rgb': L,
                      'seconds': round(time.perf_counter() - t0, 3)}))


if __name__ == '__main__':
    main()
