"""Textured dome lights against usd-core: on every shared asset whose DomeLight names a texture, our ingest
reads the map exactly when usd-core's resolver finds the file (no fallback warning then, a warning
naming the prim otherwise); and a map inside a usdz written by usd-core's packager is read from it."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from pxr import Sdf, Usd, UsdUtils

ASSETS = Path(__file__).resolve().parents[3] / "shared" / "assets"


def _dome_map_count(blob: Path) -> int:
    """Records in the blob's DomeMaps section (kind 60, 16 bytes each), read from its section table."""
    data = blob.read_bytes()
    (count,) = struct.unpack_from("<I", data, 12)
    for i in range(count):
        kind, size, _, length, _ = struct.unpack_from("<IIQQQ", data, 64 + 32 * i)
        if kind == 60:
            assert size == 16
            return length // 16
    raise AssertionError("no DomeMaps section")


def _textured_domes() -> list[tuple[Path, str, str]]:
    """(stage, dome prim path, usd-core's resolved texture path) over the shared library."""
    found = []
    if not ASSETS.is_dir():
        return found
    for layer in sorted(ASSETS.rglob("*.usda")):
        if "texture:file" not in layer.read_text(errors="replace"):
            continue
        stage = Usd.Stage.Open(str(layer))
        for prim in stage.Traverse():
            if prim.GetTypeName() not in ("DomeLight", "DomeLight_1"):
                continue
            attr = prim.GetAttribute("inputs:texture:file")
            value = attr.Get() if attr else None
            if isinstance(value, Sdf.AssetPath) and value.path:
                found.append((layer, str(prim.GetPath()), value.resolvedPath))
    return found


DOMES = _textured_domes()


def test_the_library_has_textured_domes():
    if not ASSETS.is_dir():
        pytest.skip("shared asset library absent")
    assert len({stage for stage, _, _ in DOMES}) >= 11, DOMES


@pytest.mark.parametrize("stage,prim,resolved", DOMES, ids=[f"{s.name}:{p}" for s, p, _ in DOMES])
def test_dome_texture_is_read_where_usd_core_resolves_it(ingest, stage, prim, resolved):
    result = ingest(stage, "--lenient").ok()
    ours = [line for line in result.stderr.splitlines() if prim in line and "dome texture" in line]
    if resolved and Path(resolved).is_file():
        assert ours == [], f"usd-core resolves {resolved}, ours warned: {ours}"
        assert _dome_map_count(result.blob) >= 1, "the map was not baked"
    else:
        assert ours, f"usd-core does not resolve the map of {prim}; ours did not warn:\n{result.stderr}"
        assert _dome_map_count(result.blob) == 0


def _hdr(path: Path, width: int, height: int, rgb: tuple[float, float, float]) -> None:
    """A solid flat (not run-length encoded) Radiance .hdr; `rgb` components must be 2^k multiples of
    1/256 of the largest so RGBE holds them exactly."""
    top = max(rgb)
    exponent = 0
    while top >= 1.0:
        top /= 2.0
        exponent += 1
    while top < 0.5:
        top *= 2.0
        exponent -= 1
    texel = bytes(int(c / 2.0 ** exponent * 256.0) for c in rgb) + bytes([exponent + 128])
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode()
    path.write_bytes(header + texel * (width * height))


SCENE = """#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Y"
)
def Xform "World"
{
    def Camera "Cam"
    {
        float focalLength = 500
    }
    def DomeLight "Sky"
    {
        float inputs:intensity = 2
        asset inputs:texture:file = @textures/sky.hdr@
    }
}
"""


def _srgb8(linear: float) -> int:
    encoded = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return int(min(max(encoded, 0.0), 1.0) * 255.0 + 0.5)


def test_dome_map_inside_a_usd_core_package_lights_the_background(ingest, render, tmp_path):
    (tmp_path / "textures").mkdir()
    _hdr(tmp_path / "textures" / "sky.hdr", 16, 8, (0.125, 0.25, 0.5))
    (tmp_path / "scene.usda").write_text(SCENE)
    package = tmp_path / "sky.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(tmp_path / "scene.usda")), str(package))
    result = ingest(package).ok()
    assert "dome texture" not in result.stderr, result.stderr
    assert _dome_map_count(result.blob) == 1
    png = tmp_path / "out.png"
    out = render(result.blob, "-o", tmp_path / "out.exr", "--png", png, "--res", "2x2", "--spp", "1")
    assert out.returncode == 0, out.stderr
    from test_usdz_textures import _read_png

    _, _, channels, rows = _read_png(png)
    # Every pixel is background: the map's texel × intensity 2, sRGB-encoded by the preview.
    expected = [_srgb8(2.0 * c) for c in (0.125, 0.25, 0.5)]
    for row in rows:
        for x in range(len(row) // channels):
            assert row[x * channels:x * channels + 3] == expected, (row, expected)
