"""Writes the seed corpus for the layer fuzz test (ingest/tests/fuzz_layers.rs).

Small stages in every layer format ingest reads (usda, usdc, usdz), exercising meshes, subdivision, curves,
points, materials with textures, lights, cameras, xform ops, variants, references, payloads, inherits,
instancing and time samples. Run with a Python that has usd-core: `python make_corpus.py`.
Written by this project; same licence as the repository.
"""
import os
from pxr import Usd, UsdGeom, UsdShade, UsdLux, Sdf, Gf, UsdUtils

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.environ.get("FUZZ_CORPUS_OUT", os.path.join(HERE, "corpus"))


def scene(path):
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(2)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    xf = UsdGeom.Xform.Define(stage, "/World/Group")
    xf.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    xf.AddRotateXYZOp().Set(Gf.Vec3f(10, 20, 30))
    op = xf.AddScaleOp()
    op.Set(Gf.Vec3f(1, 1, 1), 1)
    op.Set(Gf.Vec3f(2, 2, 2), 2)
    mesh = UsdGeom.Mesh.Define(stage, "/World/Group/Cube")
    mesh.CreatePointsAttr([(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
                           (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)])
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3])
    mesh.CreateSubdivisionSchemeAttr("catmullClark")
    mesh.CreateCreaseIndicesAttr([0, 1])
    mesh.CreateCreaseLengthsAttr([2])
    mesh.CreateCreaseSharpnessesAttr([3.0])
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                 UsdGeom.Tokens.faceVarying)
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)] * 6)
    mesh.CreateDisplayColorAttr([(0.8, 0.2, 0.1)])
    tri = UsdGeom.Mesh.Define(stage, "/World/Tri")
    tri.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    tri.CreateFaceVertexCountsAttr([3])
    tri.CreateFaceVertexIndicesAttr([0, 1, 2])
    tri.CreateSubdivisionSchemeAttr("none")
    curves = UsdGeom.BasisCurves.Define(stage, "/World/Hair")
    curves.CreateTypeAttr("cubic")
    curves.CreateBasisAttr("bspline")
    curves.CreateCurveVertexCountsAttr([4, 5])
    curves.CreatePointsAttr([(0, 0, 0), (0, 1, 0), (0, 2, 1), (0, 3, 1),
                             (1, 0, 0), (1, 1, 0), (1, 2, 1), (1, 3, 1), (1, 4, 2)])
    curves.CreateWidthsAttr([0.1])
    points = UsdGeom.Points.Define(stage, "/World/Dots")
    points.CreatePointsAttr([(3, 0, 0), (3, 1, 0)])
    points.CreateWidthsAttr([0.2, 0.3])
    material = UsdShade.Material.Define(stage, "/World/Looks/Red")
    shader = UsdShade.Shader.Define(stage, "/World/Looks/Red/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.4)
    reader = UsdShade.Shader.Define(stage, "/World/Looks/Red/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, "/World/Looks/Red/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("missing_<UDIM>.png")
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    light = UsdLux.RectLight.Define(stage, "/World/Key")
    light.CreateIntensityAttr(5)
    light.CreateWidthAttr(2)
    UsdLux.DomeLight.Define(stage, "/World/Dome").CreateIntensityAttr(0.5)
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    proto = stage.DefinePrim("/Proto", "Xform")
    proto.SetSpecifier(Sdf.SpecifierClass)
    inst = stage.DefinePrim("/World/Inst", "Xform")
    inst.GetInherits().AddInherit("/Proto")
    inst.GetReferences().AddInternalReference("/World/Group")
    inst.SetInstanceable(True)
    vset = world.GetPrim().GetVariantSets().AddVariantSet("look")
    for name in ("a", "b"):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            s = UsdGeom.Sphere.Define(stage, f"/World/Variant_{name}")
            s.CreateRadiusAttr(1.5 if name == "a" else 0.5)
    vset.SetVariantSelection("a")
    pi = UsdGeom.PointInstancer.Define(stage, "/World/Scatter")
    pi.CreatePrototypesRel().AddTarget("/World/Tri")
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (2, 0, 0), (4, 0, 0)])
    pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0)] * 3)
    return stage


def main():
    os.makedirs(OUT, exist_ok=True)
    stage = scene(os.path.join(OUT, "scene.usda"))
    stage.GetRootLayer().Save()
    stage.GetRootLayer().Export(os.path.join(OUT, "scene.usdc"))
    # A layer that references and payloads the first, with an offset, to fuzz the arcs' syntax.
    arcs = Usd.Stage.CreateNew(os.path.join(OUT, "arcs.usda"))
    root = arcs.DefinePrim("/Root", "Xform")
    arcs.SetDefaultPrim(root)
    root.GetReferences().AddReference("./scene.usda", layerOffset=Sdf.LayerOffset(10, 2))
    arcs.DefinePrim("/Root/Loaded").GetPayloads().AddPayload("./scene.usdc", "/World/Group")
    arcs.GetRootLayer().subLayerPaths.append("./scene.usdc")
    arcs.GetRootLayer().Save()
    arcs.GetRootLayer().Export(os.path.join(OUT, "arcs.usdc"))
    UsdUtils.CreateNewUsdzPackage(os.path.join(OUT, "scene.usda"), os.path.join(OUT, "scene.usdz"))
    # A package holding a crate file, so crate-file mutations reach the reader through a package.
    UsdUtils.CreateNewUsdzPackage(os.path.join(OUT, "scene.usdc"), os.path.join(OUT, "scene_c.usdz"))


if __name__ == "__main__":
    main()
