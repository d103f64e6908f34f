"""Tabulates the ingest's warnings over the shared asset library by feature.

    python tests/python/warning_table.py [--ingest PATH] [--assets DIR] [--json OUT]

Runs `ingest ROOT -o BLOB --lenient --subdiv-level 0 -q` on every .usd/.usda/.usdc/.usdz file under
the asset library (as test_all_assets.py does) and prints a Markdown table: per feature, how many
warnings and how many root layers produced them. Each warning line reads
`warning: FILE: PRIM: MESSAGE`; a line that does not name the file and a prim path is counted under
"unnamed" (the table should have none). Not a test: the counts describe the library, not a contract.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXTENSIONS = {".usd", ".usda", ".usdc", ".usdz"}

#: (feature, pattern on the message after `FILE: PRIM: `), first match wins.
FEATURES = [
    ("material not defined on the stage (layer not loaded)", r"bound material is not defined on the stage"),
    ("bound prim is not a Material", r"bound material is a .* prim, not a Material"),
    ("non-UsdPreviewSurface surface (RenderMan, MaterialX)", r"surface is only authored as|not UsdPreviewSurface"),
    ("layer in a format openusd cannot read (.mtlx)", r"no file format registered"),
    ("missing sublayer/reference/payload", r"(sublayer|reference|payload) @.*@ not found"),
    ("UDIM tile missing", r"UDIM tile .* is missing|UDIM: no tile file"),
    ("texture file missing", r"texture file .* not found"),
    ("texture without inputs:file", r"texture has no inputs:file"),
    ("dome texture unusable (format, missing or unreadable file)", r"dome texture .*using its uniform color"),
    ("collection-based material binding", r"collection-based material bindings"),
    ("preview-purpose binding only", r"only a preview-purpose material binding"),
    ("displacement", r"displacement ignored"),
    ("PxrDisney lobe or connected input beyond PreviewSurface", r"PxrDisney .* (not supported|is connected)"),
    ("connected input beyond constants", r"connected to a shading network"),
    ("faceVarying displayColor on a subdivision surface", r"faceVarying primvar .* on a subdivision surface"),
    ("subdivision refinement failed (cage drawn)", r"cannot subdivide"),
    ("unsupported prim type", r"prims not supported yet"),
    ("LightFilter", r"LightFilter not supported"),
    ("NURBS curve data inconsistent", r"knots has|order \d+ with|NurbsCurves skipped"),
    ("curve data inconsistent", r"curveVertexCounts sum|curves have too few vertices|widths has"),
    ("mesh without points/faces or with bad points", r"mesh has no points|expected a \d+-vector array"),
    ("xformOp listed without a value", r"is in xformOpOrder but has no value"),
    ("projective transform", r"is projective"),
    ("unknown purpose", r"unknown purpose"),
    ("time samples unreadable", r"time samples unreadable"),
]


def roots(assets: Path) -> list[Path]:
    return sorted(p for p in assets.rglob("*") if p.suffix.lower() in EXTENSIONS and p.is_file())


def classify(message: str) -> str:
    for feature, pattern in FEATURES:
        if re.search(pattern, message):
            return feature
    return "other: " + re.sub(r"\d+", "N", message)[:80]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ingest", type=Path, default=ROOT / "target" / "release" / "ingest")
    parser.add_argument("--assets", type=Path, default=ROOT.parent / "shared" / "assets")
    parser.add_argument("--json", type=Path, help="also write {root: [warning lines]} here")
    args = parser.parse_args()
    warnings: dict[str, list[str]] = {}
    counts: Counter = Counter()
    files: dict[str, set] = defaultdict(set)
    with tempfile.TemporaryDirectory() as tmp:
        for stage in roots(args.assets):
            rel = stage.relative_to(args.assets).as_posix()
            proc = subprocess.run(
                [str(args.ingest), str(stage), "-o", f"{tmp}/scene.blob", "--lenient", "--subdiv-level", "0", "-q"],
                capture_output=True, text=True, timeout=600,
            )
            lines = [line for line in proc.stderr.splitlines() if line.startswith("warning: ")]
            warnings[rel] = lines
            for line in lines:
                named = line.removeprefix("warning: ")
                prefix = f"{stage}: "
                if not named.startswith(prefix) or not named[len(prefix):].startswith("/"):
                    feature = "unnamed (no file or prim)"
                else:
                    prim, _, message = named[len(prefix):].partition(": ")
                    feature = classify(message)
                counts[feature] += 1
                files[feature].add(rel)
    if args.json:
        args.json.write_text(json.dumps(warnings, indent=1))
    total = sum(counts.values())
    print(f"{len(warnings)} root layers, {total} warnings, {sum(1 for w in warnings.values() if w)} layers warn\n")
    print("| feature | warnings | root layers |")
    print("|---|---:|---:|")
    for feature, n in counts.most_common():
        print(f"| {feature} | {n} | {len(files[feature])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
