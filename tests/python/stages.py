"""Generated USD stages for the cross-checks, as .usda text (one dict of files per stage).

Each stage exercises one area of the USD reader; `EXPECTED` pins, independently of both readers, a
few facts the stage was written to have, so a mistake in the reference listing cannot hide one in the
ingest.
"""

from __future__ import annotations

import math


def _tuple(v) -> str:
    return "(" + ", ".join(f"{x:.9g}" for x in v) + ")"


def _array(vs) -> str:
    return "[" + ", ".join(_tuple(v) for v in vs) + "]"


def _ints(vs) -> str:
    return "[" + ", ".join(str(int(v)) for v in vs) + "]"


def mesh(name: str, points, counts, indices, body: str = "", scheme: str = "none", meta: str = "") -> str:
    """A `def Mesh` prim."""
    return f"""
def Mesh "{name}" {meta}
{{
    uniform token subdivisionScheme = "{scheme}"
    int[] faceVertexCounts = {_ints(counts)}
    int[] faceVertexIndices = {_ints(indices)}
    point3f[] points = {_array(points)}
    {body}
}}
"""


def polygons(name: str, polys, body: str = "", **kw) -> str:
    """A mesh made of independent polygons (each a list of points)."""
    points = [p for poly in polys for p in poly]
    counts = [len(poly) for poly in polys]
    return mesh(name, points, counts, range(len(points)), body, **kw)


# An asymmetric hexahedron (not centred, not axis-symmetric): a wrong transform shows in its bounds.
BOX_POINTS = [
    (-0.3, 0.1, -1.2), (0.9, 0.1, -1.2), (1.1, 2.1, -1.0), (-0.3, 2.0, -1.2),
    (-0.3, 0.1, 1.8), (0.9, 0.2, 1.8), (0.9, 2.1, 1.8), (-0.4, 2.1, 1.9),
]
BOX_COUNTS = [4] * 6
BOX_INDICES = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7]


def box(name: str, body: str = "", scale: float = 1.0, **kw) -> str:
    return mesh(name, [tuple(scale * c for c in p) for p in BOX_POINTS], BOX_COUNTS, BOX_INDICES, body, **kw)


TRI = [(0.0, 0.0, 0.0), (1.5, 0.2, -0.3), (0.1, 1.0, 0.7)]


def tri(name: str, body: str = "", **kw) -> str:
    return polygons(name, [TRI], body, **kw)


def grid(name: str, n: int, body: str = "", **kw) -> str:
    """An n x n grid of quads in the XZ plane, (n + 1)^2 points."""
    points = [(float(i), 0.1 * i * j, float(j)) for j in range(n + 1) for i in range(n + 1)]
    indices = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            indices += [a, a + n + 1, a + n + 2, a + 1]
    return mesh(name, points, [4] * (n * n), indices, body, **kw)


def regular(n: int, radius: float = 1.0, z: float = 0.0, phase: float = 0.1):
    return [(radius * math.cos(phase + 2 * math.pi * k / n), radius * math.sin(phase + 2 * math.pi * k / n), z)
            for k in range(n)]


def star(points: int, outer: float, inner: float):
    return [((outer if k % 2 == 0 else inner) * math.cos(math.pi * k / points),
             (outer if k % 2 == 0 else inner) * math.sin(math.pi * k / points), 0.5) for k in range(2 * points)]


HEADER = """#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = {mpu}
    upAxis = "{up}"
    {extra}
)
"""


def header(mpu=1, up="Y", extra="") -> str:
    return HEADER.format(mpu=mpu, up=up, extra=extra)


def material(name: str, color) -> str:
    return f"""
def Material "{name}"
{{
    token outputs:surface.connect = <Surface.outputs:surface>
    def Shader "Surface"
    {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = {_tuple(color)}
        token outputs:surface
    }}
}}
"""


# --- stages -------------------------------------------------------------------------------------

XFORMS = {
    "xforms.usda": header() + f"""
def Xform "World"
{{
    double3 xformOp:translate = (1, 2, 3)
    float3 xformOp:rotateXYZ = (10, 20, 30)
    float3 xformOp:scale = (2, 1, 0.5)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]

    def Xform "Pivoted"
    {{
        double3 xformOp:translate:pivot = (0.5, -1, 0.25)
        quatf xformOp:orient = (0.9238795, 0, 0.38268343, 0)
        double xformOp:rotateX = 30
        float xformOp:rotateY:tilt = -15
        half xformOp:rotateZ = 60
        uniform token[] xformOpOrder = ["xformOp:translate:pivot", "xformOp:orient", "xformOp:rotateX", "xformOp:rotateY:tilt", "xformOp:rotateZ", "!invert!xformOp:translate:pivot"]
        {box("Box")}
    }}

    def Xform "Orders"
    {{
        float3 xformOp:rotateXZY = (10, 20, 30)
        float3 xformOp:rotateYXZ = (40, -50, 60)
        double3 xformOp:rotateYZX = (-70, 80, 5)
        float3 xformOp:rotateZXY = (15, 25, -35)
        half3 xformOp:rotateZYX = (45, 55, 65)
        uniform token[] xformOpOrder = ["xformOp:rotateXZY", "xformOp:rotateYXZ", "xformOp:rotateYZX", "xformOp:rotateZXY", "xformOp:rotateZYX"]
        {box("Box")}
    }}

    def Xform "Matrix"
    {{
        matrix4d xformOp:transform = ((0, 1, 0, 0), (-2, 0, 0, 0), (0, 0, 1, 0), (5, -1, 2, 1))
        matrix4d xformOp:transform:shear = ((1, 0, 0, 0), (0, 1, 0, 0), (0.5, 0, 1, 0), (0, 3, 0, 1))
        double3 xformOp:translate:offset = (1, 1, 1)
        float3 xformOp:scale:uneven = (1, 3, -2)
        uniform token[] xformOpOrder = ["xformOp:transform", "!invert!xformOp:transform:shear", "!invert!xformOp:translate:offset", "!invert!xformOp:scale:uneven"]
        {tri("Tri")}
    }}

    def Xform "Reset"
    {{
        double3 xformOp:translate = (-10, 4, 0)
        uniform token[] xformOpOrder = ["!resetXformStack!", "xformOp:translate"]

        def Xform "Mirrored"
        {{
            float3 xformOp:scale = (1, -1, 1)
            uniform token[] xformOpOrder = ["xformOp:scale"]
            {box("Box")}
        }}
    }}

    {box("ResetOnGprim", body='''
        float xformOp:rotateY = 90
        uniform token[] xformOpOrder = ["!resetXformStack!", "xformOp:rotateY"]''')}

    {box("UnlistedOp", body='''
        double3 xformOp:translate = (100, 0, 0)''')}

    def Scope "Scope"
    {{
        {tri("InScope", body='''
            double3 xformOp:translate = (0, 0, -4)
            uniform token[] xformOpOrder = ["xformOp:translate"]''')}
    }}
}}
""",
}

TOPOLOGY = {
    "topology.usda": header() + f"""
def Xform "World"
{{
    {polygons("Pentagon", [regular(5)])}
    {polygons("Mixed", [regular(3, z=1), regular(4, z=2), regular(5, z=3), regular(6, z=4), regular(8, z=5)])}
    {polygons("Concave", [
        [(0, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (1, 2, 0), (0, 2, 0)],
        [(3, 0, 0), (5, 1, 0), (3, 2, 0), (3.5, 1, 0)],
        star(5, 2.0, 0.7),
    ])}
    {grid("Holes", 3, body="int[] holeIndices = [0, 4, 8]")}
    {grid("FaceVaryingHole", 3, body='''
        int[] holeIndices = [4]
        texCoord2f[] primvars:st = [''' + ", ".join("(0, 0)" for _ in range(36)) + '''] (
            interpolation = "faceVarying"
        )''')}
    {polygons("AllHoles", [[(0, 5, 0), (1, 5, 0), (1, 6, 0), (0, 6, 0)]], body="int[] holeIndices = [0]")}
    {box("LeftHanded", body='uniform token orientation = "leftHanded"')}
    {polygons("Degenerate", [TRI, [(9, 9, 9), (9, 8, 9)], regular(4, z=-2), [(7, 7, -7)]])}
    {box("CatmullCage", scheme="catmullClark")}
    {box("Bilinear", scheme="bilinear", scale=2)}
    {mesh("Unreferenced", TRI + [(-20, -20, -20)], [3], [0, 1, 2])}
}}
""",
}

VISIBILITY = {
    "visibility.usda": header() + f"""
def Xform "World"
{{
    {tri("Visible")}
    {tri("Invisible", body='token visibility = "invisible"')}
    def Xform "HiddenGroup"
    {{
        token visibility = "invisible"
        {tri("Child", body='token visibility = "inherited"')}
    }}
    {tri("Guide", body='uniform token purpose = "guide"')}
    {tri("Proxy", body='uniform token purpose = "proxy"')}
    {tri("RenderOnly", body='uniform token purpose = "render"')}
    def Xform "GuideGroup"
    {{
        uniform token purpose = "guide"
        {tri("InheritsGuide")}
        {tri("AuthoredDefault", body='uniform token purpose = "default"')}
    }}
    def Xform "RenderGroup"
    {{
        uniform token purpose = "render"
        {tri("InheritsRender")}
        {tri("AuthoredProxy", body='uniform token purpose = "proxy"')}
    }}
    {tri("Inactive", meta="(active = false)")}
    over "Over"
    {{
        {tri("UnderOver")}
    }}
    def Xform "WithOverChild"
    {{
        over Mesh "NotDefined"
        {{
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }}
    }}
    def SphereLight "Lamp"
    {{
        double3 xformOp:translate = (0, 3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def SphereLight "HiddenLamp"
    {{
        token visibility = "invisible"
    }}
    def Camera "Cam"
    {{
        double3 xformOp:translate = (0, 0, 10)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
}}

class Xform "_Abstract"
{{
    {tri("InClass")}
}}
""",
}

_PART = header() .replace('defaultPrim = "World"', 'defaultPrim = "Part"') + f"""
def Xform "Part" (
    variants = {{
        string look = "short"
    }}
    prepend variantSets = "look"
)
{{
    {box("Geo")}
    variantSet "look" = {{
        "short" {{
        }}
        "tall" {{
            over "Geo"
            {{
                float3 xformOp:scale = (1, 4, 1)
                uniform token[] xformOpOrder = ["xformOp:scale"]
            }}
        }}
    }}
}}
"""

COMPOSITION = {
    "main.usda": header(extra="subLayers = [@layers/overrides.usda@, @layers/base.usda@]") + f"""
class Xform "_class_Lifted"
{{
    double3 xformOp:translate = (0, 10, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}

def Xform "World"
{{
    def "Referenced" (
        references = @assets/part.usda@</Part>
    )
    {{
        double3 xformOp:translate = (3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def "ByDefaultPrim" (
        references = @./assets/part.usda@
        variants = {{
            string look = "tall"
        }}
    )
    {{
        double3 xformOp:translate = (-3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def "Internal" (
        references = </World/Referenced>
    )
    {{
        double3 xformOp:translate = (0, 0, 6)
    }}

    def Xform "Variant" (
        variants = {{
            string shape = "big"
        }}
        prepend variantSets = "shape"
    )
    {{
        variantSet "shape" = {{
            "small" {{
                {box("Body", scale=0.5)}
            }}
            "big" {{
                {box("Body", scale=3, body='''
                    double3 xformOp:translate = (0, 0, -20)
                    uniform token[] xformOpOrder = ["xformOp:translate"]''')}
            }}
        }}
    }}

    def Xform "Inheriting" (
        inherits = </_class_Lifted>
    )
    {{
        {box("Body")}
    }}
}}
""",
    "layers/base.usda": """#usda 1.0
over "World"
{
    over "Referenced"
    {
        double3 xformOp:translate = (99, 0, 0)
    }

    def "FromSublayerRef" (
        references = @../assets/part.usda@</Part>
    )
    {
        double3 xformOp:translate = (0, -7, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
""" + tri("FromSublayer") + "}\n",
    "layers/overrides.usda": """#usda 1.0
over "_class_Lifted"
{
    float xformOp:rotateZ = 45
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
}

over "World"
{
    over "ByDefaultPrim"
    {
        over "Geo"
        {
            point3f[] points = """ + _array(BOX_POINTS[:7] + [(-0.4, 2.1, 7.5)]) + """
        }
    }
}
""",
    "assets/part.usda": _PART,
}

PAYLOAD = {
    "payload.usda": header() + f"""
def Xform "World"
{{
    def Xform "Heavy" (
        prepend payload = @assets/heavy.usda@</Heavy>
    )
    {{
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    {tri("AlwaysThere")}
}}
""",
    "assets/heavy.usda": """#usda 1.0
def Xform "Heavy"
{
""" + box("Body") + """
    def "Part" (
        references = @part.usda@</Part>
    )
    {
        double3 xformOp:translate = (4, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
""",
    "assets/part.usda": _PART,
}
PAYLOAD_GPRIMS = {"/World/Heavy/Body", "/World/Heavy/Part/Geo"}

INSTANCING = {
    "instancing.usda": header() + f"""
class Xform "_Proto"
{{
    {box("Geo")}
    def Xform "Sub"
    {{
        float xformOp:rotateX = 90
        uniform token[] xformOpOrder = ["xformOp:rotateX"]
        {tri("Tri")}
    }}
}}

def Xform "World"
{{
    def "A" (
        instanceable = true
        references = </_Proto>
    )
    {{
        double3 xformOp:translate = (10, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def "B" (
        instanceable = true
        references = </_Proto>
    )
    {{
        double3 xformOp:translate = (-10, 0, 0)
        float xformOp:rotateY = 30
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    }}

    def "C" (
        instanceable = false
        references = </_Proto>
    )
    {{
        float3 xformOp:scale = (2, 2, 2)
        uniform token[] xformOpOrder = ["xformOp:scale"]
    }}

    def PointInstancer "Scatter"
    {{
        double3 xformOp:translate = (0, 20, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        point3f[] positions = [(0, 0, 0), (5, 0, 0), (0, 5, 0), (0, 0, 5), (7, 7, 7)]
        quatf[] orientationsf = [(1, 0, 0, 0), (0.70710677, 0, 0.70710677, 0), (0, 1, 0, 0), (0.5, 0.5, 0.5, 0.5), (1, 0, 0, 0)]
        float3[] scales = [(1, 1, 1), (2, 2, 2), (1, 0.5, 1), (1, 1, 3), (1, 1, 1)]
        int[] protoIndices = [0, 1, 0, 1, 0]
        int64[] invisibleIds = [4]
        rel prototypes = [</World/Scatter/Protos/Boxy>, </World/Scatter/Protos/Tri>]

        def Scope "Protos"
        {{
            def Xform "Boxy"
            {{
                double3 xformOp:translate = (0.5, 0, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                {box("Geo")}
                {tri("HiddenInProto", body='token visibility = "invisible"')}
            }}
            {tri("Tri")}
        }}
    }}
}}
""",
}

# An instanceable prim inside an instance's prototype whose reference targets a prim of that same
# prototype (</Inner/Proto>): the pattern of OpenUSD's ni_ni_* instancing tests, reduced. The
# material bound inside Proto is listed under each instance's own namespace (…/Nested/Red).
NESTED_INSTANCING = {
    "nested_instancing.usda": header() + f"""
def Xform "World"
{{
    def Xform "Inner"
    {{
        def Xform "Proto"
        {{
            {tri("Tri", meta='(prepend apiSchemas = ["MaterialBindingAPI"])',
                 body="rel material:binding = </World/Inner/Proto/Red>")}
            {material("Red", (1, 0, 0))}
        }}

        def "Nested" (
            instanceable = true
            references = </World/Inner/Proto>
        )
        {{
            double3 xformOp:translate = (0, 3, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }}
    }}

    def "Outer" (
        instanceable = true
        references = </World/Inner>
    )
    {{
        double3 xformOp:translate = (5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def "OuterNotInstanced" (
        references = </World/Inner>
    )
    {{
        double3 xformOp:translate = (-5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
}}
""",
}

MATERIALS = {
    "materials.usda": header() + f"""
def Xform "World"
{{
    def Scope "Looks"
    {{
        {material("Red", (1, 0, 0))}
        {material("Green", (0, 1, 0))}
        {material("Blue", (0, 0, 1))}
    }}

    {box("Subsets", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='''
        rel material:binding = </World/Looks/Red>
        uniform token subsetFamily:materialBind:familyType = "nonOverlapping"
        def GeomSubset "Top" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [0, 1]
            rel material:binding = </World/Looks/Green>
        }
        def GeomSubset "Side" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [2]
            rel material:binding = </World/Looks/Blue>
        }''')}

    {box("FullyCovered", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='''
        rel material:binding = </World/Looks/Red>
        def GeomSubset "Half" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [0, 1, 2]
            rel material:binding = </World/Looks/Green>
        }
        def GeomSubset "Rest" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [3, 4, 5]
            rel material:binding = </World/Looks/Blue>
        }''')}

    {box("UnboundSubset", body='''
        def GeomSubset "NoBinding"
        {
            uniform token elementType = "face"
            uniform token familyName = "materialBind"
            int[] indices = [0]
        }''')}

    {box("Unbound")}

    def Xform "Group" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        rel material:binding = </World/Looks/Blue>
        {tri("InheritsBinding")}
        {tri("OwnBinding", meta='(prepend apiSchemas = ["MaterialBindingAPI"])',
             body="rel material:binding = </World/Looks/Red>")}
    }}

    def Xform "Strong" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        rel material:binding = </World/Looks/Green> (
            bindMaterialAs = "strongerThanDescendants"
        )
        {tri("Overridden", meta='(prepend apiSchemas = ["MaterialBindingAPI"])',
             body="rel material:binding = </World/Looks/Red>")}
    }}

    {tri("FullPurpose", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='''
        rel material:binding = </World/Looks/Green>
        rel material:binding:full = </World/Looks/Blue>''')}

    {tri("ShapeNotMaterial", meta='(prepend apiSchemas = ["MaterialBindingAPI"])',
         body="rel material:binding = </World/Looks>")}

    def Cube "BoundCube" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        double size = 3
        rel material:binding = </World/Looks/Blue>
        double3 xformOp:translate = (0, -5, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def Sphere "Ball"
    {{
        double radius = 0.75
        double3 xformOp:translate = (4, -5, 1)
        float xformOp:rotateZ = 30
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    }}
}}
""",
}

ZUP = {
    "zup.usda": header(mpu=0.01, up="Z") + f"""
def Xform "World"
{{
    float xformOp:rotateX = 90
    uniform token[] xformOpOrder = ["xformOp:rotateX"]
    {box("Body", scale=50)}
    def DistantLight "Sun"
    {{
        float inputs:intensity = 3
    }}
    def RectLight "Panel"
    {{
        double3 xformOp:translate = (0, 0, 300)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def Camera "Cam"
    {{
        double3 xformOp:translate = (0, -500, 100)
        float xformOp:rotateX = 80
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
    }}
}}
""",
}

# Every implicit shape: fallbacks, authored sizes, each axis, a rotation (the tessellation's bounds
# lie between its extreme vertices and usd-core's extent), a binding, displayColor, a hidden and a
# guide shape, and values the ingest refuses (warned and skipped; usd_reference skips them too).
IMPLICIT = {
    "implicit.usda": header() + """
def Xform "World"
{
    def Scope "Looks"
    {
        def Material "Red"
        {
            token outputs:surface.connect = </World/Looks/Red/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (1, 0, 0)
                token outputs:surface
            }
        }
    }
    def Cube "Cube"
    {
    }
    def Sphere "Sphere"
    {
        double3 xformOp:translate = (3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Cylinder "Cylinder"
    {
        double3 xformOp:translate = (6, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Cone "Cone"
    {
        double3 xformOp:translate = (9, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Capsule "Capsule"
    {
        double3 xformOp:translate = (12, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Plane "Plane"
    {
        double3 xformOp:translate = (15, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Xform "Authored"
    {
        double3 xformOp:translate = (0, 5, 0)
        float xformOp:rotateZ = 30
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
        def Cylinder "LogX" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            double radius = 0.25
            double height = 3
            uniform token axis = "X"
            rel material:binding = </World/Looks/Red>
        }
        def Cone "SpikeY"
        {
            double radius = 0.5
            double height = 4
            uniform token axis = "Y"
            color3f[] primvars:displayColor = [(0, 0.5, 1)]
        }
        def Capsule "PillX"
        {
            double radius = 1
            double height = 2
            uniform token axis = "X"
        }
        def Plane "FloorY"
        {
            double width = 4
            double length = 6
            uniform token axis = "Y"
        }
        def Plane "WallX"
        {
            double width = 4
            double length = 6
            uniform token axis = "X"
        }
        def Sphere "Ball"
        {
            double radius = 2
        }
        def Cube "Box"
        {
            double size = 0.5
        }
    }
    def Capsule "Hidden"
    {
        token visibility = "invisible"
    }
    def Cone "Guide"
    {
        uniform token purpose = "guide"
    }
    def Sphere "Negative"
    {
        double radius = -1
    }
    def Cylinder "BadAxis"
    {
        uniform token axis = "W"
    }
}
""",
}

# Imaging semantics usd-core applies that a naive reader gets wrong (issue 23's conformance
# classes): visibility and purpose count only on Imageable prims (a typeless prim's are ignored),
# and only `materialBind` GeomSubsets bind materials.
CONFORMANCE = {
    "conformance.usda": header(extra='fallbackPrimTypes = {\n        token[] StudioMesh = ["NotASchema", "Mesh"]\n    }') + f"""
def Xform "World"
{{
    def Scope "Looks"
    {{
        {material("Red", (1, 0, 0))}
        {material("Green", (0, 1, 0))}
    }}
    def "TypelessHidden"
    {{
        token visibility = "invisible"
        {tri("UnderTypeless")}
    }}
    def "TypelessGuide"
    {{
        uniform token purpose = "guide"
        {tri("UnderTypelessGuide")}
    }}
    def Material "Glslfx"
    {{
        token outputs:surface.connect = </World/Glslfx/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "StudioCustomSurface"
            token outputs:surface
        }}
    }}
    def Material "NoSurface"
    {{
    }}
    {tri("BoundCustom", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='rel material:binding = </World/Glslfx>')}
    {tri("BoundEmpty", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='rel material:binding = </World/NoSurface>')}
    def StudioMesh "Custom"
    {{
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(2, 0, 0), (3, 0, 0), (2, 1, 0)]
    }}
    def Xform "ImageableHidden"
    {{
        token visibility = "invisible"
        {tri("UnderImageable")}
    }}
    {box("OtherFamily", meta='(prepend apiSchemas = ["MaterialBindingAPI"])', body='''
        rel material:binding = </World/Looks/Red>
        def GeomSubset "Partition" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            uniform token familyName = "partition"
            int[] indices = [0, 1]
            rel material:binding = </World/Looks/Green>
        }
        def GeomSubset "Unnamed" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            uniform token elementType = "face"
            int[] indices = [2]
            rel material:binding = </World/Looks/Green>
        }''')}
}}
""",
}


def _deep_references(depth: int) -> dict[str, str]:
    """A chain of `depth` layers, each referencing the next's `/P`: the mesh is authored only in the
    last, and two levels author a translate, so the shallower one (level 250) must win."""
    files = {}
    for i in range(depth):
        last = i == depth - 1
        meta = "" if last else f"(\n    prepend references = @l{i + 1}.usda@</P>\n)"
        body = box("Geo") if last else ""
        if i in (250, 400):
            body += f"\n    double3 xformOp:translate = ({i}, 0, 0)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]"
        files[f"l{i}.usda"] = header() + f'def Xform "P" {meta}\n{{\n    {body}\n}}\n'
    return files


#: A 500-deep acyclic reference chain, which usd-core composes (upstream openusd 0.6 stopped at 100).
DEEP_REFERENCES = _deep_references(500)

GENERATED = {
    "xforms": XFORMS,
    "topology": TOPOLOGY,
    "visibility": VISIBILITY,
    "composition": COMPOSITION,
    "payload": PAYLOAD,
    "instancing": INSTANCING,
    "nested_instancing": NESTED_INSTANCING,
    "materials": MATERIALS,
    "zup": ZUP,
    "implicit": IMPLICIT,
    "conformance": CONFORMANCE,
    "deep_references": DEEP_REFERENCES,
}

# Facts each stage was written to have, checked against the usd-core listing.
EXPECTED = {
    "deep_references": {"paths": {"/P/Geo"}},
    "conformance": {
        "paths": {
            "/World/TypelessHidden/UnderTypeless", "/World/TypelessGuide/UnderTypelessGuide", "/World/OtherFamily",
            "/World/Custom", "/World/BoundCustom", "/World/BoundEmpty",
        },
        "materials": {
            "/World/OtherFamily": {"/World/Looks/Red"},
            "/World/BoundCustom": {"/World/Glslfx"},
            "/World/BoundEmpty": {"/World/NoSurface"},
        },
    },
    "implicit": {
        "paths": {
            f"/World/{p}" for p in (
                "Cube", "Sphere", "Cylinder", "Cone", "Capsule", "Plane", "Authored/LogX", "Authored/SpikeY",
                "Authored/PillX", "Authored/FloorY", "Authored/WallX", "Authored/Ball", "Authored/Box",
            )
        },
        "triangles": {
            "/World/Cube": 12, "/World/Sphere": 960, "/World/Cylinder": 128, "/World/Cone": 64,
            "/World/Capsule": 1024, "/World/Plane": 2,
        },
        "materials": {"/World/Authored/LogX": {"/World/Looks/Red"}, "/World/Authored/SpikeY": set()},
    },
    "xforms": {
        "paths": {
            "/World/Pivoted/Box", "/World/Orders/Box", "/World/Matrix/Tri", "/World/Reset/Mirrored/Box",
            "/World/ResetOnGprim", "/World/UnlistedOp", "/World/Scope/InScope",
        },
    },
    "payload": {"paths": {"/World/AlwaysThere", "/World/Heavy/Body", "/World/Heavy/Part/Geo"}},
    "zup": {"paths": {"/World/Body"}, "lights": 2, "cameras": 1},
    "visibility": {
        "paths": {
            "/World/Visible", "/World/RenderOnly", "/World/GuideGroup/AuthoredDefault",
            "/World/RenderGroup/InheritsRender",
        },
        "lights": 1,
        "cameras": 1,
    },
    "topology": {
        "triangles": {
            "/World/Pentagon": 3,
            "/World/Mixed": 1 + 2 + 3 + 4 + 6,
            "/World/Concave": 4 + 2 + 8,
            "/World/Holes": 2 * (9 - 3),
            "/World/FaceVaryingHole": 2 * 8,
            "/World/AllHoles": 0,
            "/World/LeftHanded": 12,
            "/World/Degenerate": 1 + 2,
            "/World/CatmullCage": 12,
            "/World/Bilinear": 12,
            "/World/Unreferenced": 1,
        },
    },
    "materials": {
        "materials": {
            "/World/Subsets": {"/World/Looks/Red", "/World/Looks/Green", "/World/Looks/Blue"},
            "/World/FullyCovered": {"/World/Looks/Green", "/World/Looks/Blue"},
            "/World/UnboundSubset": set(),
            "/World/Unbound": set(),
            "/World/Group/InheritsBinding": {"/World/Looks/Blue"},
            "/World/Group/OwnBinding": {"/World/Looks/Red"},
            "/World/Strong/Overridden": {"/World/Looks/Green"},
            "/World/FullPurpose": {"/World/Looks/Blue"},
            "/World/BoundCube": {"/World/Looks/Blue"},
            "/World/Ball": set(),
        },
    },
    "instancing": {
        # 3 references of _Proto (2 gprims each) + 4 visible PointInstancer instances (1 gprim each).
        "count": 3 * 2 + 4,
    },
    "nested_instancing": {
        "paths": {
            f"/World/{outer}/{inner}/Tri"
            for outer in ("Inner", "Outer", "OuterNotInstanced") for inner in ("Proto", "Nested")
        },
        "materials": {
            f"/World/{outer}/{inner}/Tri": frozenset([f"/World/{outer}/{inner}/Red"])
            for outer in ("Inner", "Outer", "OuterNotInstanced") for inner in ("Proto", "Nested")
        },
    },
    "composition": {
        "paths": {
            "/World/Referenced/Geo", "/World/ByDefaultPrim/Geo", "/World/Internal/Geo",
            "/World/Variant/Body", "/World/Inheriting/Body", "/World/FromSublayer",
            "/World/FromSublayerRef/Geo",
        },
    },
}


# --- negative cases -----------------------------------------------------------------------------

MISSING_REFERENCE = {
    "root.usda": header() + """
def Xform "World"
{
    def "Thing" (
        references = @missing_part.usda@</Part>
    )
    {
    }
}
""",
}

MISSING_IN_SUBLAYER = {
    "root.usda": header(extra="subLayers = [@layers/mid.usda@]") + 'def Xform "World"\n{\n}\n',
    "layers/mid.usda": """#usda 1.0
over "World"
{
    def "Thing" (
        references = @../missing_part.usda@</Part>
    )
    {
    }
}
""",
}

MISSING_SUBLAYER = {
    "root.usda": header(extra="subLayers = [@layers/not_there.usda@]") + 'def Xform "World"\n{\n}\n',
}

MISSING_PAYLOAD = {
    "root.usda": header() + """
def Xform "World"
{
    def "Thing" (
        prepend payload = @missing_payload.usda@</Heavy>
    )
    {
    }
}
""" + tri("Kept"),
}

MALFORMED_ROOT = {
    "broken_root.usda": header() + """
def Xform "World"
{
    def Mesh "Bad"
    {
        int[] faceVertexCounts = [3
        point3f[] points = [(0, 0, 0), (1, 0, 0)
    }
""",
}

MALFORMED_REFERENCED = {
    "root.usda": header() + """
def Xform "World"
{
    def "Thing" (
        references = @assets/broken_part.usda@</Part>
    )
    {
    }
}
""",
    "assets/broken_part.usda": """#usda 1.0
def Xform "Part"
{
    def Mesh "Geo" {
        point3f[] points = [(0, 0, 0), (1, 0, 0), ((
}
""",
}

NEGATIVE = {
    "missing_reference": MISSING_REFERENCE,
    "missing_in_sublayer": MISSING_IN_SUBLAYER,
    "missing_sublayer": MISSING_SUBLAYER,
    "missing_payload": MISSING_PAYLOAD,
    "malformed_root": MALFORMED_ROOT,
    "malformed_referenced": MALFORMED_REFERENCED,
}
