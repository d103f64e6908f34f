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


def _membership(stage: Usd.Stage) -> dict[str, tuple[list[str], list[str]]]:
    """Per gprim (instance proxies included): the lights whose lightLink and shadowLink hold it."""
    lights = [p for p in stage.Traverse() if p.HasAPI(UsdLux.LightAPI)]
    queries = {
        name: [(str(l.GetPath()), Usd.CollectionAPI(l, name).ComputeMembershipQuery()) for l in lights]
        for name in ("lightLink", "shadowLink")
    }
    out = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.Mesh):
            path = prim.GetPath()
            out[str(path)] = tuple([l for l, q in queries[name] if q.IsPathIncluded(path)] for name in ("lightLink", "shadowLink"))
    return out


def _listed(dump: dict) -> dict[str, tuple[list[str], list[str]]]:
    return {g["path"]: (g["light_link"], g["shadow_link"]) for g in dump["gprims"]}


def test_light_sets_equal_usd_core_membership(ingest):
    result = ingest(STAGE).ok()
    expected = _membership(Usd.Stage.Open(str(STAGE)))
    assert len(expected) == 7
    assert _listed(result.dump) == expected
    # The stage really links: some gprim is left out of some light's collections.
    assert any(len(lit) < 4 or len(shadows) < 4 for lit, shadows in expected.values())


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
    assert _listed(result.dump) == _membership(Usd.Stage.Open(str(path)))
