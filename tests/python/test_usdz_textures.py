"""A texture inside a usdz written by usd-core's own packager (`UsdUtils.CreateNewUsdzPackage`: stored,
64-byte-aligned entries) is read from the package: an emissive card shows the texel."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

from pxr import UsdUtils


def _png(path: Path, width: int, height: int, rgb: tuple[int, int, int]) -> None:
    """A solid 8-bit RGB PNG."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\x00" + bytes(rgb) * width for _ in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def _read_png(path: Path) -> tuple[int, int, int, list[list[int]]]:
    """Width, height, channels and rows of an 8-bit non-interlaced PNG (all five row filters)."""
    data = path.read_bytes()
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 8
            channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw, stride, rows, prev = zlib.decompress(idat), width * channels, [], [0] * (width * channels)
    for y in range(height):
        f, line = raw[y * (stride + 1)], list(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b, c = prev[i], prev[i - channels] if i >= channels else 0
            p = a + b - c
            pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= min(abs(p - b), abs(p - c)) else (b if abs(p - b) <= abs(p - c) else c)][f]
            line[i] = (line[i] + pred) & 0xFF
        rows.append(line)
        prev = line
    return width, height, channels, rows


SCENE = """#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Y"
)
def Xform "World"
{
    def Camera "Cam"
    {
        token projection = "orthographic"
        float horizontalAperture = 20
        float verticalAperture = 20
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Mesh "Card" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
        rel material:binding = </World/M>
    }
    def Material "M"
    {
        token outputs:surface.connect = </World/M/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0, 0, 0)
            color3f inputs:emissiveColor.connect = </World/M/Tex.outputs:rgb>
            token outputs:surface
        }
        def Shader "Tex"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @textures/card.png@
            float2 inputs:st.connect = </World/M/St.outputs:result>
            float3 outputs:rgb
        }
        def Shader "St"
        {
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }
    }
}
"""


def test_usd_core_package_texture_is_read_from_the_zip(ingest, render, tmp_path):
    source = tmp_path / "src"
    (source / "textures").mkdir(parents=True)
    (source / "scene.usda").write_text(SCENE)
    _png(source / "textures" / "card.png", 4, 4, (200, 100, 50))
    package = tmp_path / "card.usdz"
    assert UsdUtils.CreateNewUsdzPackage(str(source / "scene.usda"), str(package))
    # Nothing beside the package: the texture can only come from inside it.
    for f in sorted((source / "textures").iterdir()):
        f.unlink()
    result = ingest(package).ok()
    assert "card.png" not in result.stderr, result.stderr
    out = tmp_path / "card.png"
    rendered = render(result.blob, "-o", tmp_path / "card.exr", "--png", out, "--spp", "1", "--res", "8x8")
    assert rendered.returncode == 0, rendered.stderr
    _, _, channels, rows = _read_png(out)
    for row in rows:
        for x in range(8):
            # The emissive texel, decoded to linear and re-encoded to sRGB for the preview: the code itself.
            assert all(abs(row[x * channels + c] - v) <= 1 for c, v in enumerate((200, 100, 50))), row
