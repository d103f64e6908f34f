#!/usr/bin/env python3
"""Reads every MaterialX look in a folder of USD assets (shared/assets) with `ingest` and reports
the warnings left, by node category.

Outside the test suite: the assets are not in a user's clone. Each `.mtlx` document is wrapped in a
USD layer that references its `/MaterialX/Materials` and binds every material to a triangle; each USD
layer with `ND_` shaders or `.mtlx` arcs is read as it is, and the Standard Shader Ball once per
`material_model` and `example_material` variant. Warnings naming a MaterialX node carry its category
(`MaterialX node "hsvtorgb" (...)`); the others are grouped by their text.

    scripts/materialx-survey.py [ASSETS_DIR] [--ingest target/release/ingest]
"""

import argparse
import collections
import json
import pathlib
import re
import subprocess
import sys
import tempfile

TRIANGLE = """def Mesh "{name}" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    float2[] primvars:st = [(0, 0), (1, 0), (0, 1)] (interpolation = "vertex")
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/{material}>
}}
"""


def mtlx_wrapper(document: pathlib.Path) -> str:
    names = re.findall(r'<surfacematerial\s+name="([^"]+)"', document.read_text())
    text = f'#usda 1.0\ndef Scope "Looks" (references = @{document}@</MaterialX/Materials>) {{}}\n'
    for i, name in enumerate(names):
        text += TRIANGLE.format(name=f"Tri{i}", material=name)
    return text


def shader_ball_wrappers(root: pathlib.Path):
    for model in ["standard_surface", "OpenPBRSurface"]:
        for example in ["none", "mtlx_bubblegum", "mtlx_glass", "mtlx_gold", "mtlx_plastic"]:
            yield (
                f"shader ball {model} {example}",
                f"""#usda 1.0
(
    subLayers = [@{root}@]
)
over "standard_shader_ball_scene" (variants = {{ string example_material = "{example}" }})
{{
    over "materials" (variants = {{ string material_model = "{model}" }})
    {{
        over "examples" (variants = {{ string material_model = "{model}" }}) {{}}
    }}
}}
""",
            )


def run(ingest: str, layer: pathlib.Path, listing: pathlib.Path):
    out = subprocess.run(
        [ingest, str(layer), "--dump-json", str(listing), "-o", str(listing.with_suffix(".blob"))],
        capture_output=True,
        text=True,
    )
    warnings = [l[len("warning: "):] for l in out.stderr.splitlines() if l.startswith("warning: ")]
    materials = json.loads(listing.read_text())["materials"] if out.returncode == 0 else []
    listing.with_suffix(".blob").unlink(missing_ok=True)
    return out.returncode, out.stderr.strip().splitlines()[-1:] if out.returncode else [], warnings, materials


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("assets", nargs="?", default="../shared/assets")
    parser.add_argument("--ingest", default="target/release/ingest")
    args = parser.parse_args()
    assets = pathlib.Path(args.assets).resolve()
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for i, document in enumerate(sorted(assets.rglob("*.mtlx"))):
            layer = tmp / f"mtlx{i}.usda"
            layer.write_text(mtlx_wrapper(document))
            cases.append((str(document.relative_to(assets)), layer))
        for layer in sorted(assets.rglob("*.usd*")):
            text = layer.read_bytes()
            if b"ND_" in text or b".mtlx" in text:
                cases.append((str(layer.relative_to(assets)), layer))
        for root in assets.rglob("standard_shader_ball_scene.usda"):
            for j, (name, text) in enumerate(shader_ball_wrappers(root)):
                layer = tmp / f"ball{j}.usda"
                layer.write_text(text)
                cases.append((name, layer))
        by_category = collections.Counter()
        models = collections.Counter()
        categories = set()
        for name, layer in cases:
            code, error, warnings, materials = run(args.ingest, layer, tmp / "list.json")
            for m in materials:
                if m["surface_model"] in ("standard_surface", "open_pbr_surface") or any(
                    c[0].islower() for c in m["node_categories"]
                ):
                    models[m["surface_model"]] += 1
                    categories.update(m["node_categories"])
            print(f"{name}: {'error ' + error[0] if code else str(len(warnings)) + ' warnings'}")
            for w in warnings:
                print(f"    {w}")
                node = re.search(r'MaterialX node "([^"]+)"', w)
                key = f"node {node.group(1)}" if node else re.sub(r"^/\S+: ", "", w)
                key = re.sub(r"(/[\w./-]+)", "<path>", key)
                by_category[key] += 1
        print("\nMaterialX materials read, by surface model:", dict(models))
        print("node categories read:", sorted(categories))
        print("warnings left, by node category or kind:")
        for key, n in by_category.most_common():
            print(f"  {n:4}  {key}")


if __name__ == "__main__":
    sys.exit(main())
