"""Makes the Alembic test assets from USD with Blender's Python module (`pip install bpy==5.0.1`).

    python make_abc.py            # writes tractor.abc, shapes.abc and animated.abc here

Each asset is a USD stage imported into an empty Blender scene and exported with the Alembic
exporter. The options are pinned so that the .abc stays comparable to the USD it came from:

- no triangulation and no modifiers applied, so polygon counts match the USD;
- Blender imports a Y-up stage by rotating it to Z-up and the Alembic exporter rotates back to
  Alembic's Y-up, so world coordinates come out as in the USD (the tests check this);
- `use_instancing=False`: every object is written out, as the USD reader expands instances;
- `subdiv_schema=True` with `import_subdivision=True`: a catmullClark USD mesh becomes a Blender
  Subdivision Surface modifier and is written as an Alembic SubD (cage plus creases), not refined;
- `face_sets=True`: material assignments become face sets (Alembic has no materials);
- animated.abc holds frames 1..10 (one sample per frame at 24 fps), so the animated Xform has
  time samples; static objects get one sample.
"""

import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", "..", ".."))

# A generated stage with one of each schema the Alembic reader maps: a catmullClark cage with a
# crease under nested transforms, an animated transform, curves, points, a camera and a hidden mesh.
SHAPES_USDA = """#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
    startTimeCode = 1
    endTimeCode = 10
    timeCodesPerSecond = 24
)

def Xform "World"
{
    def Xform "Rig"
    {
        double3 xformOp:translate = (0, 1, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]

        def Xform "Arm"
        {
            double3 xformOp:translate = (-3, 0, 0)
            float xformOp:rotateY = 30
            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]

            def Mesh "Cage"
            {
                uniform token subdivisionScheme = "catmullClark"
                int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
                int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4]
                point3f[] points = [(-1, -1, 1), (1, -1, 1), (-1, 1, 1), (1, 1, 1), (-1, 1, -1), (1, 1, -1), (-1, -1, -1), (1, -1, -1)]
                int[] creaseIndices = [2, 3, 5, 4, 2]
                int[] creaseLengths = [5]
                float[] creaseSharpnesses = [10]
            }
        }
    }

    def Xform "Mover"
    {
        double3 xformOp:translate.timeSamples = {
            1: (0, 0, 0),
            10: (4.5, 0, 0),
        }
        uniform token[] xformOpOrder = ["xformOp:translate"]

        def Mesh "Box"
        {
            uniform token subdivisionScheme = "none"
            int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
            int[] faceVertexIndices = [0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4]
            point3f[] points = [(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (-0.5, 0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), (0.5, 0.5, -0.5), (-0.5, -0.5, -0.5), (0.5, -0.5, -0.5)]
        }
    }

    def BasisCurves "Hair"
    {
        uniform token type = "linear"
        int[] curveVertexCounts = [4, 3, 5]
        point3f[] points = [(0, 0, 3), (0, 1, 3), (0, 2, 3.2), (0, 3, 3.5),
                            (1, 0, 3), (1, 1, 3), (1, 2, 3.3),
                            (2, 0, 3), (2, 0.5, 3), (2, 1, 3.1), (2, 1.5, 3.2), (2, 2, 3.4)]
        float[] widths = [0.1] (interpolation = "constant")
    }

    def NurbsCurves "Arc"
    {
        int[] curveVertexCounts = [5]
        int[] order = [4]
        double[] knots = [0, 0, 0, 0, 1, 2, 2, 2, 2]
        double2[] ranges = [(0, 2)]
        point3f[] points = [(3, 0, 0), (4, 1, 0), (5, 0, 0), (6, 1, 0), (7, 0, 0)]
        float[] widths = [0.1] (interpolation = "constant")
    }

    def Points "Dots"
    {
        point3f[] points = [(-2, 3, 0), (-1, 3, 0), (0, 3, 0), (1, 3, 0), (2, 3, 0)]
        float[] widths = [0.2, 0.2, 0.2, 0.2, 0.2] (interpolation = "vertex")
    }

    def Mesh "Hidden"
    {
        token visibility = "invisible"
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, -5, 0), (1, -5, 0), (0, -4, 0)]
    }

    def Camera "Camera"
    {
        float focalLength = 35
        float horizontalAperture = 36
        float verticalAperture = 24
        float2 clippingRange = (0.1, 1000)
        double3 xformOp:translate = (0, 1.5, 14)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"""


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def export(path, frames):
    scene = bpy.context.scene
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = frames
    scene.frame_set(frames[0])
    bpy.ops.wm.alembic_export(
        filepath=path,
        start=frames[0],
        end=frames[1],
        uvs=True,
        normals=True,
        face_sets=True,
        subdiv_schema=True,
        apply_subdiv=False,
        triangulate=False,
        use_instancing=False,
        flatten=False,
        export_custom_properties=False,
        orcos=False,
        evaluation_mode="RENDER",
        global_scale=1.0,
    )
    print("wrote", path, os.path.getsize(path), "bytes")


def import_usd(path):
    bpy.ops.wm.usd_import(
        filepath=path,
        import_subdivision=True,
        import_visible_only=False,
        import_lights=False,
        import_materials=True,
        create_world_material=False,
        set_frame_range=False,
        apply_unit_conversion_scale=True,
        merge_parent_xform=False,
    )


def points_as_particles(name):
    """Blender imports USD Points as a point cloud, which its Alembic exporter skips; it writes
    particle systems as Alembic Points instead. So the cloud is replaced by a vertex-only mesh of
    the same name whose vertices emit one particle each, in vertex order, at the first frame,
    without physics. (The emitter mesh has no faces; the USD reader skips it.)"""
    cloud = bpy.data.objects[name]
    positions = [tuple(p.vector) for p in cloud.data.attributes["position"].data]
    matrix = cloud.matrix_world.copy()
    bpy.data.objects.remove(cloud)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(positions, [], [])
    emitter = bpy.data.objects.new(name, mesh)
    emitter.matrix_world = matrix
    bpy.context.scene.collection.objects.link(emitter)
    emitter.modifiers.new(name, type="PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count = len(positions)
    settings.emit_from = "VERT"
    settings.use_emit_random = False
    settings.frame_start = settings.frame_end = 1
    settings.lifetime = 1000
    settings.physics_type = "NO"
    settings.render_type = "NONE"


def hide(name):
    """Blender writes Alembic `visible = 0` for an emitter that is not rendered, and has no
    other way to write it (objects hidden from rendering are left out): the USD-invisible mesh
    gets a one-particle system and is hidden as an emitter."""
    obj = bpy.data.objects[name]
    obj.modifiers.new(name, type="PARTICLE_SYSTEM")
    settings = obj.particle_systems[0].settings
    settings.count = 1
    settings.frame_start = settings.frame_end = 1
    settings.physics_type = "NO"
    settings.render_type = "NONE"
    obj.show_instancer_for_render = False


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else HERE
    reset()
    import_usd(os.path.join(REPO, "examples", "tractor.usda"))
    export(os.path.join(out, "tractor.abc"), (1, 1))

    shapes = os.path.join(out, "shapes.usda")
    with open(shapes, "w") as f:
        f.write(SHAPES_USDA)
    # Blender 5.0.1 crashes exporting particles over more than one frame here, so the points go
    # into a one-frame archive and the animation into another without them.
    reset()
    import_usd(shapes)
    points_as_particles("Dots")
    hide("Hidden")
    export(os.path.join(out, "shapes.abc"), (1, 1))
    reset()
    import_usd(shapes)
    bpy.data.objects.remove(bpy.data.objects["Dots"])
    export(os.path.join(out, "animated.abc"), (1, 10))
    os.remove(shapes)

if __name__ == "__main__":
    main()
