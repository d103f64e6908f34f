"""Light and shadow linking against usd-core: the light sets `ingest --dump-json` lists for every gprim
(`light_link`, `shadow_link`) equal `Usd.CollectionAPI(light, 'lightLink' | 'shadowLink')
.ComputeMembershipQuery().IsPathIncluded(gprim)` for every light, on a stage with includes, excludes,
`explicitOnly`, `includeRoot` off and instance proxies (tests/assets/light_linking/linked.usda), and on
variants of it built here with usd-core's API."""

from __future__ import annotations

from pathlib import Path

import pytest
from pxr import Sdf, Usd, UsdGeom, UsdLux

STAGE = Path(__file__).resolve().parents[1] / "assets" / "light_linking" / "linked.usda"
# Pixar's own linking test stage (includes, excludes, includeRoot off, a face-set target).
PIXAR = (
    Path(__file__).resolve().parents[3] / "shared" / "assets" / "openusd_lights_cameras" / "pxr" / "usd"
    / "usdLux" / "testenv" / "testUsdLuxLinkingAPI" / "linking_example.usda"
)


def _membership(stage: Usd.Stage, gprims) -> dict[str, tuple[list[str], list[str]]]:
    """Per gprim path: the lights (traversal order) whose lightLink and shadowLink hold it."""
    lights = [
        p for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies())
        if p.HasAPI(UsdLux.LightAPI) and p.GetTypeName() in ("DistantLight", "SphereLight", "RectLight", "DiskLight", "DomeLight")
    ]
    queries = {
        name: [(str(l.GetPath()), Usd.CollectionAPI(l, name).ComputeMembershipQuery()) for l in lights]
        for name in ("lightLink", "shadowLink")
    }
    return {
        path: tuple([l for l, q in queries[name] if q.IsPathIncluded(Sdf.Path(path))] for name in ("lightLink", "shadowLink"))
        for path in gprims
    }


def _listed(dump: dict) -> dict[str, tuple[list[str], list[str]]]:
    return {g["path"]: (g["light_link"], g["shadow_link"]) for g in dump["gprims"]}


def test_light_sets_equal_usd_core_membership(ingest):
    result = ingest(STAGE).ok()
    stage = Usd.Stage.Open(str(STAGE))
    meshes = [str(p.GetPath()) for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()) if p.IsA(UsdGeom.Mesh)]
    assert sorted(_listed(result.dump)) == sorted(meshes) and len(meshes) == 7
    expected = _membership(stage, meshes)
    assert _listed(result.dump) == expected
    # The stage really links: some gprim is left out of some light's collections.
    assert any(len(lit) < 4 or len(shadows) < 4 for lit, shadows in expected.values())


@pytest.mark.skipif(not PIXAR.is_file(), reason="shared asset library not present")
def test_pixars_linking_example_equals_usd_core_membership(ingest):
    result = ingest(PIXAR).ok()
    listed = _listed(result.dump)
    assert sorted(listed) == ["/Geom/a", "/Geom/b", "/Geom/meshWithFaceSet"]
    assert listed == _membership(Usd.Stage.Open(str(PIXAR)), listed)
    # The face-set target links no whole gprim (usd-core agrees); ingest says so.
    assert "face subsets" in result.stderr or "GeomSubset" in result.stderr


@pytest.mark.parametrize("edit", ["exclude_below_include", "explicit_with_root", "include_inside_exclude"])
def test_edited_collections_equal_usd_core_membership(ingest, tmp_path, edit):
    stage = Usd.Stage.Open(str(STAGE))
    key = Usd.CollectionAPI(stage.GetPrimAtPath("/Key"), "lightLink")
    fill = Usd.CollectionAPI(stage.GetPrimAtPath("/Fill"), "shadowLink")
    if edit == "exclude_below_include":
        key.GetIncludesRel().SetTargets([Sdf.Path("/World")])
        key.GetExcludesRel().SetTargets([Sdf.Path("/World/A"), Sdf.Path("/World/Inst3")])
    elif edit == "explicit_with_root":
        key.CreateExpansionRuleAttr("explicitOnly")
        key.CreateIncludeRootAttr(True)
        key.GetIncludesRel().SetTargets([Sdf.Path("/World/B/b1"), Sdf.Path("/World/Inst1/geo")])
    else:
        fill.CreateIncludeRootAttr(False)
        fill.CreateIncludesRel().SetTargets([Sdf.Path("/World/A/a2"), Sdf.Path("/World/Inst2")])
        fill.GetExcludesRel().SetTargets([Sdf.Path("/World/A")])
    path = tmp_path / f"{edit}.usda"
    stage.GetRootLayer().Export(str(path))
    result = ingest(path).ok()
    listed = _listed(result.dump)
    assert len(listed) == 7
    assert listed == _membership(Usd.Stage.Open(str(path)), listed)


def test_a_stage_without_lights_is_warned_about(ingest, tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "dark.usda"))
    UsdGeom.Sphere.Define(stage, "/Ball")
    stage.Save()
    result = ingest(tmp_path / "dark.usda").ok()
    assert "/: the stage has no light" in result.stderr, result.stderr
    UsdLux.DistantLight.Define(stage, "/Sun")
    stage.Save()
    result = ingest(tmp_path / "dark.usda").ok()
    assert "no light" not in result.stderr, result.stderr
