"""Cross-checks of the Rust ingest (and `render --info`) against Pixar's usd-core.

For every stage, `ingest --dump-json` must list the same drawn gprims as usd-core (see
usd_reference.py for the exact conventions), with equal triangle counts, world bounds within
max(1, |scene extent|) * 1e-5 (plus float32 rounding) and the same bound materials; `render --info`
must report the same totals. Stages: generated ones (stages.py), the bundled example and curated
real assets copied under tests/assets (see tests/assets/README.md), and negative cases (missing and
malformed layers, corrupted blobs).
"""

from __future__ import annotations

import copy
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd

import stages
from conftest import ROOT
from usd_reference import F32_EPS, Listing, compare, tolerance, usd_listing

ASSETS = ROOT / "tests" / "assets"
EXAMPLES = ROOT / "examples"
CAR_KIT = EXAMPLES / "mini_car_kit" / "USD_Mini_Car_Kit" / "assets"


# --- helpers ------------------------------------------------------------------------------------


def write_stage(root: Path, files: dict[str, str]) -> Path:
    """Writes a stage's files under `root`; returns the first (root layer) path."""
    paths = []
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        paths.append(path)
    return paths[0]


def expected_triangles(dump: dict, ref: Listing) -> int:
    """usd-core's triangle total, with our counts for implicit spheres and subdivision meshes (whose
    counts `compare` checks per gprim against the level the dump reports)."""
    ours = {g.path for g in ref.gprims if g.triangles is None or g.scheme is not None}
    return (sum(g.triangles for g in ref.gprims if g.path not in ours)
            + sum(e["triangles"] for e in dump["gprims"] if e["path"] in ours))


def check_render_info(info: dict, dump: dict, ref: Listing) -> list[str]:
    """Differences between `render --info` and the usd-core totals."""
    problems = []
    totals = {
        "meshes": len(ref.gprims),
        "triangles": expected_triangles(dump, ref),
        "lights": ref.lights,
        "cameras": ref.cameras,
    }
    for key, want in totals.items():
        if info.get(key) != want:
            problems.append(f"render --info {key}: {info.get(key)}, usd-core {want}")
    if info.get("triangles") != sum(e["triangles"] for e in dump["gprims"]):
        problems.append(f"render --info triangles {info.get('triangles')} != sum over --dump-json")
    with_points = [g for g in ref.gprims if g.lo is not None]
    if with_points:
        atol = tolerance(ref)
        # A subdivision surface lies inside its cage, which the dump lists as its bounds: it
        # bounds the rendered box from outside only; polygon meshes from both sides.
        polygons = [g for g in with_points if g.scheme is None]
        inner_lo = np.min([g.lo for g in polygons], axis=0) if polygons else np.full(3, np.inf)
        inner_hi = np.max([g.hi for g in polygons], axis=0) if polygons else np.full(3, -np.inf)
        outer_lo = np.min([g.lo if g.outer_lo is None else g.outer_lo for g in with_points], axis=0)
        outer_hi = np.max([g.hi if g.outer_hi is None else g.outer_hi for g in with_points], axis=0)
        # The blob's positions are relative to its world origin (camera-relative storage).
        origin = np.asarray(info["world_origin"], float)
        lo, hi = np.asarray(info["bounds_min"], float) + origin, np.asarray(info["bounds_max"], float) + origin
        slack = lambda v: atol + 4 * F32_EPS * np.abs(v)  # noqa: E731
        if not (np.all(lo >= outer_lo - slack(outer_lo)) and np.all(lo <= inner_lo + slack(inner_lo))
                and np.all(hi >= inner_hi - slack(inner_hi)) and np.all(hi <= outer_hi + slack(outer_hi))):
            problems.append(
                f"render --info bounds {lo.tolist()}..{hi.tolist()}, usd-core "
                f"{np.round(inner_lo, 6).tolist()}..{np.round(inner_hi, 6).tolist()}"
            )
    return problems


def crosscheck(ingest, render_info, stage: Path, *flags, time=None, load_payloads=True) -> Listing:
    """Ingests `stage` and asserts the listing and the render totals match usd-core."""
    result = ingest(stage, *flags).ok()
    ref = usd_listing(stage, time=time, load_payloads=load_payloads)
    problems = compare(result.dump, ref)
    problems += check_render_info(render_info(result.blob), result.dump, ref)
    assert not problems, f"{stage.name}: ours differs from usd-core:\n  " + "\n  ".join(problems)
    return ref


# --- generated stages ---------------------------------------------------------------------------


@pytest.fixture(scope="session")
def generated(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("stages")
    return {name: write_stage(root / name, files) for name, files in stages.GENERATED.items()}


@pytest.mark.parametrize("name", sorted(stages.GENERATED))
def test_generated_stage_is_valid_usd(generated, name):
    """usd-core composes every generated stage without errors (so a difference is the ingest's)."""
    stage = Usd.Stage.Open(str(generated[name]))
    assert stage, name
    assert not stage.GetCompositionErrors(), [str(e) for e in stage.GetCompositionErrors()]


@pytest.mark.parametrize("name", sorted(stages.GENERATED))
def test_generated_stage_matches_usd_core(ingest, render_info, generated, name):
    ref = crosscheck(ingest, render_info, generated[name])
    # The reference itself must show what the stage was written to contain.
    expected = stages.EXPECTED.get(name, {})
    paths = {g.path for g in ref.gprims}
    if "paths" in expected:
        assert paths == expected["paths"]
    if "count" in expected:
        assert len(ref.gprims) == expected["count"]
    for key in ("lights", "cameras"):
        if key in expected:
            assert getattr(ref, key) == expected[key]
    by_path = {g.path: g for g in ref.gprims}
    for path, triangles in expected.get("triangles", {}).items():
        assert by_path[path].triangles == triangles, path
    for path, materials in expected.get("materials", {}).items():
        assert by_path[path].materials == materials, path


def test_comparison_catches_differences(ingest, generated):
    """The comparison is not vacuous: each kind of perturbation of a correct listing is reported,
    and a perturbation within the tolerance is not."""
    stage = generated["xforms"]
    dump = ingest(stage).ok().dump
    ref = usd_listing(stage)
    assert not compare(dump, ref)
    atol = tolerance(ref)

    def perturbed(edit):
        d = copy.deepcopy(dump)
        edit(d["gprims"])
        return compare(d, ref)

    def shift(gprims, amount):
        gprims[0]["bounds_max"][1] += amount

    assert perturbed(lambda g: shift(g, 0.2 * atol)) == []
    assert perturbed(lambda g: shift(g, 3 * atol))
    assert perturbed(lambda g: g[0].__setitem__("triangles", g[0]["triangles"] + 1))
    assert perturbed(lambda g: g[0]["materials"].append("/World/Looks/Extra"))
    assert perturbed(lambda g: g.pop())
    assert perturbed(lambda g: g.append(copy.deepcopy(g[0])))
    assert perturbed(lambda g: g[0].__setitem__("path", g[0]["path"] + "_renamed"))


def test_no_payloads_drops_the_payload(ingest, render_info, generated):
    stage = generated["payload"]
    loaded = {g.path for g in usd_listing(stage).gprims}
    assert stages.PAYLOAD_GPRIMS <= loaded
    unloaded = crosscheck(ingest, render_info, stage, "--no-payloads", load_payloads=False)
    paths = {g.path for g in unloaded.gprims}
    assert paths == loaded - stages.PAYLOAD_GPRIMS


@pytest.mark.parametrize(
    "name, missing, kept",
    [("missing_payload", "missing_payload.usda", ["/Kept"]), ("missing_reference", "missing_part.usda", [])],
)
def test_lenient_skips_a_missing_file(ingest, tmp_path, name, missing, kept):
    """--lenient: the missing file is a warning naming it, and everything else is still read."""
    stage = write_stage(tmp_path, stages.NEGATIVE[name])
    result = ingest(stage, "--lenient").ok()
    assert missing in result.stderr
    assert [e["path"] for e in result.dump["gprims"]] == kept


# --- real assets --------------------------------------------------------------------------------

USDWG = ASSETS / "usdwg_conformance" / "test_assets"
OPENUSD_INSTANCING = ASSETS / "openusd_instancing" / "pxr"
GL_INSTANCING = OPENUSD_INSTANCING / "usdImaging" / "usdImagingGL" / "testenv"
PREVIEW_SURFACE = (ASSETS / "openusd_preview_surface" / "pxr" / "usdImaging" / "usdImagingGL" / "testenv"
                   / "testUsdImagingGLPreviewSurface")
OPENUSD_SUBDIV = ASSETS / "openusd_subdiv"
GL_SUBDIV = OPENUSD_SUBDIV / "pxr" / "usdImaging" / "usdImagingGL" / "testenv"

# Time-sampled assets are checked at the stage's startTimeCode ('@start'), the time the ingest
# evaluates at by default (time samples win over defaults); a usd-core reference at
# Usd.TimeCode.Default() would check a time the ingest never reads.




ASSET_CASES = [
    # The bundled example and the Mini Car Kit (references, variants, GeomSubsets, textures).
    (EXAMPLES / "tractor.usda", None, ()),
    (CAR_KIT / "vehicles" / "vehicleVariants.usda", None, ()),
    (CAR_KIT / "wheels" / "wheelVariants.usda", None, ()),
    # usd-wg conformance: transforms.
    *[(USDWG / "schemaTests/usdGeom/transforms" / f, None, ()) for f in (
        "simple_transform.usda", "complex_transform.usda", "matrix_transform.usda", "xforms_nested.usda",
        "scopes_and_xforms_nested.usda")],
    # A projective xformOp:transform (last column (4, 8, 12, 1)): points are divided through, as usd-core does.
    (USDWG / "schemaTests/usdGeom/transforms/weird_matrix_transform.usda", None, ()),
    # usd-wg conformance: mesh topology and implicit shapes.
    *[(USDWG / "schemaTests/usdGeom/meshes" / f, None, ()) for f in (
        "5_face/5_face.usda", "mixed_faceVertexCounts/mixed.usda", "triangled_mesh/triangles.usda",
        "quad_mesh/quads.usda", "subdiv_loop_triangles/subdiv_loop_triangles.usda",
        "normals_types/normalsTypes.usda", "empty_mesh/empty.usda")],
    (USDWG / "schemaTests/usdGeom/primitives/all_primitives.usda", None, ()),
    (USDWG / "_common/teapot.usda", None, ()),
    # usd-wg conformance: composition.
    *[(USDWG / "foundation/stage_composition" / f, None, ()) for f in (
        "class_inherit.usda", "inherit_and_specialize.usda", "over.usda", "active.usda",
        "payload/payload_same_folder.usda", "payload/payload_child_folder.usda",
        "payload/payload_parent_folder.usda", "references/reference_same_folder.usda",
        "references/reference_child_folder.usda", "references/reference_parent_folder.usda",
        "subLayer/sublayer_same_folder.usda", "subLayer/sublayer_child_folder.usda",
        "subLayer/sublayer_parent_folder.usda")],
    # A Cube with `purpose = "other"` (not an allowed token): usd-core computes purpose "other", which is
    # neither default nor render, so it is not drawn.
    (USDWG / "foundation/stage_composition/purpose.usda", None, ()),
    (USDWG / "RelationshipEncapsulationTests/ReferencedAssembliesWithInternalReferencesTest.usda", None, ()),
    (USDWG / "TextureTransformTest/TextureTransformTest.usd", None, ()),
    (USDWG / "TextureCoordinateTest/TextureCoordinateTest.usda", None, ()),
    (USDWG / "RoughnessTest/RoughnessTest.usdz", None, ()),
    (USDWG / "USDZ/AnimatedCube/AnimatedCube.usdz", None, ()),
    # OpenUSD: native instancing and PointInstancers.
    (OPENUSD_INSTANCING / "usd/usdGeom/testenv/testUsdGeomBBoxCache/cubeSbdv_instanced.usda", "start", ()),
    (GL_INSTANCING / "testUsdImagingGLInstancing/instancedCubes.usda", None, ()),
    (GL_INSTANCING / "testUsdImagingGLInstancing/nestedInstancedCubes.usda", None, ()),
    # Nested native instances (an instanceable prim inside an instance's prototype) and material
    # bindings on instances at both levels.
    (GL_INSTANCING / "testUsdImagingGLInstancingWithMaterials/ni_ni_material_binding_resolution.usda", None, ()),
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_basic.usda", None, ()),
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/ni_pi_xform.usda", None, ()),
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_ni.usda", None, ()),
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_ni_pi.usda", None, ()),
    # quath orientations that are not unit length after half rounding (|q|^2 = 1.00013).
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_pi.usda", None, ()),
    # `inactiveIds = [3]` list-op metadata on the PointInstancer.
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_masking.usda", "start", ()),
    (GL_INSTANCING / "testUsdImagingGLPointInstancer/pi_varying.usda", "start", ()),
    # OpenUSD: preview surface tests (leftHanded, implicit shapes, instanced materials).
    *[(PREVIEW_SURFACE / f, None, ()) for f in (
        "testPreviewSurfacePrimvarReaderOpacity.usda", "testPreviewSurfaceTranslucent.usda",
        "testPreviewSurfaceInstancedMaterial.usda", "testPreviewSurfaceTextureWithToken.usda",
        "testPreviewSurfaceSourceColorSpace.usda")],
    # OpenUSD: holes and face-varying / left-handed meshes.
    (GL_SUBDIV / "testUsdImagingGLHoleFaces/holeFaces.usda", None, ()),
    (GL_SUBDIV / "testUsdImagingGLMeshQuadrangulation/meshQuadrangulation.usda", None, ()),
    (GL_SUBDIV / "testUsdImagingGLFaceVarying/testUsdImagingGLFaceVaryingLeftHanded.usda", None, ()),
    # The material's only surface is RenderMan's PxrDisney (`outputs:ri:surface`), read by the ingest.
    (OPENUSD_SUBDIV / "extras/usd/tutorials/endToEnd/assets/Table/Table.usd", None, ()),
    # usd-wg: subdivision pyramids (payloads, variants, inherits, instanceable, animated xforms).
    (ASSETS / "subdiv_pyramids/full_assets/SubdivisionSurfaces/Creases_SpinningPyramids.usda", None, ()),
]


def _case_id(path: Path, time) -> str:
    try:
        rel = path.relative_to(ASSETS)
        rel = Path(rel.parts[0]) / path.name
    except ValueError:
        rel = path.relative_to(ROOT)
    return f"{rel}@{time}" if time else str(rel)


@pytest.mark.parametrize(
    "path, time",
    [pytest.param(p, t, marks=m, id=_case_id(p, t)) for p, t, m in ASSET_CASES],
)
def test_asset_matches_usd_core(ingest, render_info, path, time):
    assert path.is_file(), f"missing test asset {path}"
    crosscheck(ingest, render_info, path, time=time)


def test_asset_payloads_can_be_left_unloaded(ingest, render_info):
    stage = USDWG / "foundation/stage_composition/payload/payload_same_folder.usda"
    ref = crosscheck(ingest, render_info, stage, "--no-payloads", load_payloads=False)
    assert not ref.gprims


# --- negative cases -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, layer, missing",
    [
        ("missing_reference", "root.usda", "missing_part.usda"),
        ("missing_in_sublayer", "mid.usda", "missing_part.usda"),
        ("missing_sublayer", "root.usda", "not_there.usda"),
        ("missing_payload", "root.usda", "missing_payload.usda"),
    ],
)
def test_missing_file_names_the_referencing_layer(ingest, tmp_path, name, layer, missing):
    stage = write_stage(tmp_path, stages.NEGATIVE[name])
    result = ingest(stage)
    assert result.returncode > 0, result.stderr
    assert layer in result.stderr, f"stderr does not name the referencing layer {layer}:\n{result.stderr}"
    assert missing in result.stderr, f"stderr does not name the missing file {missing}:\n{result.stderr}"
    assert "panicked" not in result.stderr


@pytest.mark.parametrize(
    "stage, layer, missing",
    [
        ("references/reference_invalid.usda", "reference_invalid.usda", "file_does_not_exist.usda"),
        ("payload/payload_invalid.usda", "payload_invalid.usda", "file_does_not_exist.usda"),
        ("subLayer/sublayer_invalid.usda", "sublayer_invalid.usda", "file_does_not_exist.usda"),
    ],
)
def test_asset_with_missing_file_fails_naming_it(ingest, stage, layer, missing):
    path = USDWG / "foundation/stage_composition" / stage
    assert missing in path.read_text()
    result = ingest(path)
    assert result.returncode > 0, result.stderr
    assert layer in result.stderr and missing in result.stderr, result.stderr
    assert "panicked" not in result.stderr


@pytest.mark.parametrize(
    "name, bad_file", [("malformed_root", "broken_root.usda"), ("malformed_referenced", "broken_part.usda")]
)
def test_malformed_usda_fails_naming_the_file(ingest, tmp_path, name, bad_file):
    stage = write_stage(tmp_path, stages.NEGATIVE[name])
    result = ingest(stage)
    assert result.returncode > 0, result.stderr
    assert bad_file in result.stderr, f"stderr does not name {bad_file}:\n{result.stderr}"
    assert "panicked" not in result.stderr


def test_missing_root_layer_fails(ingest, tmp_path):
    result = ingest(tmp_path / "nowhere.usda")
    assert result.returncode > 0
    assert "nowhere.usda" in result.stderr
    assert "panicked" not in result.stderr


@pytest.fixture(scope="module")
def good_blob(binaries, tmp_path_factory) -> bytes:
    root = tmp_path_factory.mktemp("blob")
    stage = write_stage(root, stages.MATERIALS)
    blob = root / "scene.blob"
    subprocess.run([str(binaries.ingest), str(stage), "-o", str(blob), "-q"], check=True, capture_output=True)
    return blob.read_bytes()


def _flip(data: bytes, offset: int) -> bytes:
    b = bytearray(data)
    b[offset] ^= 0xA5
    return bytes(b)


BLOB_DAMAGE = {
    "empty": lambda d: b"",
    "one_byte": lambda d: d[:1],
    "header_only": lambda d: d[:64],
    "half": lambda d: d[: len(d) // 2],
    "minus_one_byte": lambda d: d[:-1],
    "appended": lambda d: d + b"\0" * 4096,
    "flipped_magic": lambda d: _flip(d, 0),
    "flipped_header_byte": lambda d: _flip(d, 24),
    "flipped_middle_byte": lambda d: _flip(d, len(d) // 2),
    "flipped_last_data_byte": lambda d: _flip(d, len(d.rstrip(b"\0")) - 1),
    # padding is checked to be zero, so even the last byte of the file counts
    "flipped_last_padding_byte": lambda d: _flip(d, len(d) - 1),
    "zeroed_tail": lambda d: d[: len(d) // 3] + b"\0" * (len(d) - len(d) // 3),
    "random_bytes": lambda d: np.random.default_rng(7).integers(0, 256, len(d), dtype=np.uint8).tobytes(),
    "text": lambda d: b"#usda 1.0\n" * 100,
}


@pytest.mark.parametrize("damage", sorted(BLOB_DAMAGE))
def test_damaged_blob_is_an_error_not_a_panic(render, good_blob, tmp_path, damage):
    blob = tmp_path / f"{damage}.blob"
    blob.write_bytes(BLOB_DAMAGE[damage](good_blob))
    for args in ((blob, "--info"), (blob, "-o", tmp_path / "out.exr", "--spp", "1", "--res", "8x8")):
        result = render(*args)
        assert result.returncode > 0, f"render {args[1:]} on a {damage} blob exited {result.returncode}"
        assert result.stderr.strip(), f"render {args[1:]} on a {damage} blob printed no message"
        assert "panicked" not in result.stderr, result.stderr
        assert not (tmp_path / "out.exr").exists()


def test_good_blob_renders(render, good_blob, tmp_path):
    """The undamaged blob of the damage tests is valid (so each failure above is the damage's)."""
    blob = tmp_path / "good.blob"
    blob.write_bytes(good_blob)
    assert render(blob, "--info").returncode == 0
    result = render(blob, "-o", tmp_path / "out.exr", "--spp", "1", "--res", "8x8")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "out.exr").is_file()


def test_missing_blob_is_an_error(render, tmp_path):
    result = render(tmp_path / "absent.blob", "--info")
    assert result.returncode > 0
    assert "absent.blob" in result.stderr
    assert "panicked" not in result.stderr
