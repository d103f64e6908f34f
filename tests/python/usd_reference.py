"""The reference side of the cross-checks: what Pixar's usd-core says a stage renders.

`usd_listing` composes a stage with usd-core and lists every drawn gprim the way `ingest --dump-json`
does: path, world bounds of its points, triangle count and bound materials. `compare` checks an
`ingest --dump-json` listing against it and returns every difference as a readable line.

Conventions shared with the ingest (see ingest/src/usd/mod.rs):

* gprims: `Mesh` prims, plus the implicit Cube, Sphere, Cylinder, Cone, Capsule and Plane that the
  ingest tessellates (32 segments around, 16 rings pole to pole: `IMPLICIT_TRIANGLES`); a shape
  with a negative or non-finite size or an axis not X/Y/Z is skipped with a warning, as ours is;
  drawn = `ComputeVisibility() != invisible` and `ComputePurpose()` in {default, render}.
* traversal: `Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)`, so native instances are listed
  under their instance proxy paths.
* PointInstancer: prototype subtrees are not drawn as themselves; each instance draws its prototype
  subtree once (the same path repeats per instance). Visibility/purpose inside a prototype are
  resolved from the prototype root down, starting from the instancer's own state.
* triangles: sum of (n - 2) over faces with n >= 3 that are not listed in `holeIndices`.
  Subdivision meshes (`subdivisionScheme` other than `none`) are refined uniformly to the level
  the ingest reports as `subdiv_level` L (chosen from the render camera, so read from the dump):
  catmullClark and bilinear make 4^L quads of a quad and n * 4^(L-1) of an n-gon (L >= 1;
  OpenSubdiv refines a catmullClark cage with non-quads at least once, so L >= 1 there; bilinear
  n-gons at L = 0 are fanned into n - 2 triangles), two triangles per quad; loop makes 4^L
  triangles of a triangle. Holes make nothing, and with `interpolateBoundary = none` neither
  does any face with a vertex on the boundary (OpenSubdiv tags those as holes). A subdivision
  mesh the ingest could not refine (no `subdiv_level`; it warns) is its triangulated cage. A mesh
  tessellated per edge (`subdiv_mode` adaptive, the default) has between one segment per cage
  edge and level L's count, L being as fine as its finest edge.
* bounds: the mesh points transformed by `ComputeLocalToWorldTransform` (not authored extents).
  For a subdivision mesh too: the listing reports its cage's world bounds (USD's extent of the
  mesh; the limit surface lies inside), so they must be equal, holes and all.
* materials: per face, the material bound to a `materialBind` GeomSubset holding the face, else the
  gprim's bound material (`ComputeBoundMaterial` for the "full" purpose); the set over drawn faces.
  No material = the ingest's synthetic `<gprim>.displayColor` material.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdShade, Vt

#: Light types the ingest reads (others are warned about and dropped).
SUPPORTED_LIGHTS = ("DomeLight", "DomeLight_1", "DistantLight", "SphereLight", "RectLight", "DiskLight")
F32_EPS = float(np.finfo(np.float32).eps)


@dataclass
class Gprim:
    path: str
    kind: str  # "Mesh" or the implicit shape's type
    triangles: int | None  # None: not compared
    lo: np.ndarray | None  # world bounds; None for a mesh without points
    hi: np.ndarray | None
    materials: frozenset
    # For a round implicit shape, bounds of its analytic surface: ours must lie between lo/hi (the
    # tessellation's extreme vertices) and outer_lo/outer_hi (usd-core's extent; a sphere's exact box).
    outer_lo: np.ndarray | None = None
    outer_hi: np.ndarray | None = None
    # Subdivision meshes: the scheme token, the sizes of the faces that reach the surface, and
    # whether every cage face is a quad (None for polygon meshes and implicit shapes).
    scheme: str | None = None
    face_sizes: list[int] = field(default_factory=list)
    all_quads: bool = False

    def subdiv_triangles(self, level: int) -> int:
        """Triangles of this subdivision mesh refined uniformly to `level` (see the module docs)."""
        if self.scheme == "loop":
            return len(self.face_sizes) * 4**level
        if self.scheme == "catmullClark" and level == 0 and not self.all_quads:
            level = 1
        if level == 0:
            return sum(n - 2 for n in self.face_sizes)
        return sum(2 * 4**level if n == 4 else 2 * n * 4 ** (level - 1) for n in self.face_sizes)

    def adaptive_triangle_range(self, level: int) -> tuple[int, int]:
        """Bounds on the triangles of a per-edge (adaptive) tessellation whose finest edge is as
        fine as `level`: at least one segment per edge (a quad is 2 triangles, a triangle 1, an
        n-gon a fan of n), at most uniform `level` (at least 1)."""
        low = sum(2 if n == 4 else 1 if n == 3 else n for n in self.face_sizes)
        return low, self.subdiv_triangles(max(level, 1))


@dataclass
class Listing:
    gprims: list[Gprim] = field(default_factory=list)
    lights: int = 0
    cameras: int = 0

    @property
    def triangles(self) -> int:
        return sum(g.triangles or 0 for g in self.gprims)

    def bounds(self):
        los = [g.lo for g in self.gprims if g.lo is not None]
        his = [g.hi for g in self.gprims if g.hi is not None]
        if not los:
            return None, None
        return np.min(los, axis=0), np.max(his, axis=0)


def _matrix(m: Gf.Matrix4d) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


def _transform(points: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Row-vector points times a USD (row-vector) matrix, with the homogeneous divide
    (Gf.Matrix4d.Transform semantics)."""
    h = np.c_[points, np.ones(len(points))] @ m
    return h[:, :3] / h[:, 3:4]


def _drawn(prim: Usd.Prim, time) -> bool:
    img = UsdGeom.Imageable(prim)
    if img.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
        return False
    return img.ComputePurpose() in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)


def _bound_material(prim: Usd.Prim) -> str | None:
    # The "full" (render) purpose, falling back to all-purpose bindings, as a final-frame renderer.
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(UsdShade.Tokens.full)
    return str(material.GetPath()) if material else None


def _mesh_record(prim: Usd.Prim, world: np.ndarray, time) -> Gprim | None:
    mesh = UsdGeom.Mesh(prim)
    points = mesh.GetPointsAttr().Get(time)
    counts = list(mesh.GetFaceVertexCountsAttr().Get(time) or [])
    if not points or not counts:
        return None  # nothing to draw (the ingest warns and skips it)
    if not isinstance(points, (Vt.Vec3fArray, Vt.Vec3dArray, Vt.Vec3hArray)):
        return None  # points declared with a non-3-vector type (int[], double[]): skipped, with a warning
    pts = np.array(points, dtype=np.float64).reshape(-1, 3)
    holes = set(mesh.GetHoleIndicesAttr().Get(time) or [])
    drawn_faces = [i for i, n in enumerate(counts) if n >= 3 and i not in holes]
    triangles = sum(counts[i] - 2 for i in drawn_faces)
    whole = _bound_material(prim)
    face_material = {i: whole for i in drawn_faces}
    for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
        if subset.GetElementTypeAttr().Get() != UsdGeom.Tokens.face:
            continue
        material = _bound_material(subset.GetPrim())
        for i in subset.GetIndicesAttr().Get(time) or []:
            if i in face_material:
                face_material[i] = material
    materials = frozenset(m for m in face_material.values() if m is not None)
    w = _transform(pts, world)
    record = Gprim(str(prim.GetPath()), "Mesh", triangles, w.min(axis=0), w.max(axis=0), materials)
    scheme = mesh.GetSubdivisionSchemeAttr().Get(time) or UsdGeom.Tokens.catmullClark
    if scheme != UsdGeom.Tokens.none:
        record.scheme = str(scheme)
        record.all_quads = all(n == 4 for n in counts)
        surface = drawn_faces
        if mesh.GetInterpolateBoundaryAttr().Get(time) == UsdGeom.Tokens.none:
            boundary = _boundary_vertices(counts, list(mesh.GetFaceVertexIndicesAttr().Get(time) or []))
            starts = np.concatenate([[0], np.cumsum(counts)])
            indices = list(mesh.GetFaceVertexIndicesAttr().Get(time) or [])
            surface = [i for i in drawn_faces
                       if not any(v in boundary for v in indices[starts[i]:starts[i] + counts[i]])]
        record.face_sizes = [counts[i] for i in surface]
    return record


def _boundary_vertices(counts, indices) -> set:
    """Vertices on an edge used by exactly one face."""
    edges = defaultdict(int)
    start = 0
    for n in counts:
        face = indices[start:start + n]
        start += n
        for a, b in zip(face, face[1:] + face[:1]):
            edges[(min(a, b), max(a, b))] += 1
    return {v for e, uses in edges.items() if uses == 1 for v in e}


#: The ingest's tessellation rule (ingest/src/usd/implicit.rs): segments around, rings pole to pole.
SEGMENTS, RINGS = 32, 16
#: Triangles per implicit shape under that rule.
IMPLICIT_TRIANGLES = {
    "Cube": 12,
    "Sphere": 2 * SEGMENTS * RINGS - 2 * SEGMENTS,
    "Cylinder": 4 * SEGMENTS,
    "Cone": 2 * SEGMENTS,
    "Capsule": 2 * SEGMENTS * RINGS,
    "Plane": 2,
}


def _spine(points: list, axis: str) -> np.ndarray:
    """Points built with their spine along Z, moved onto `axis` (the ingest's cyclic permutation)."""
    p = np.array(points, dtype=np.float64)
    return {"Z": p, "X": p[:, [2, 0, 1]], "Y": p[:, [1, 2, 0]]}[axis]


def _implicit_points(prim: Usd.Prim, kind: str, time) -> tuple[np.ndarray, bool]:
    """Local points every tessellation of the shape holds (its extreme vertices), and whether they
    are its corners exactly (the flat shapes) rather than inside its analytic extent."""
    get = lambda name: prim.GetAttribute(name).Get(time)  # noqa: E731 (usd-core applies fallbacks)
    if kind == "Cube":
        h = get("size") / 2.0
        return np.array([[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)]), True
    if kind == "Sphere":
        r = get("radius")
        return np.array([[s * r if k == a else 0.0 for k in range(3)] for a in range(3) for s in (-1, 1)]), False
    axis = get("axis")
    if kind == "Plane":
        w, l = get("width") / 2.0, get("length") / 2.0
        a, b = (w, l) if axis == "Z" else (l, w)
        return _spine([[i * a, j * b, 0.0] for i in (-1, 1) for j in (-1, 1)], axis), True
    r, h = get("radius"), get("height") / 2.0
    rim = lambda z: [[r, 0, z], [-r, 0, z], [0, r, z], [0, -r, z]]  # noqa: E731
    if kind == "Cylinder":
        return _spine(rim(h) + rim(-h), axis), False
    if kind == "Cone":
        return _spine(rim(-h) + [[0, 0, h]], axis), False
    return _spine(rim(h) + rim(-h) + [[0, 0, h + r], [0, 0, -h - r]], axis), False


def _implicit_valid(prim: Usd.Prim, time) -> bool:
    """Whether the ingest draws this shape: sizes finite and non-negative, axis X, Y or Z."""
    for name in ("size", "radius", "height", "width", "length"):
        attr = prim.GetAttribute(name)
        if attr:
            v = attr.Get(time)
            if v is None or not np.isfinite(v) or v < 0:
                return False
    axis = prim.GetAttribute("axis")
    return not axis or axis.Get(time) in ("X", "Y", "Z")


def _shape_record(prim: Usd.Prim, world: np.ndarray, time) -> Gprim:
    material = _bound_material(prim)
    materials = frozenset([material] if material else [])
    kind = str(prim.GetTypeName())
    points, exact = _implicit_points(prim, kind, time)
    w = _transform(points, world)
    record = Gprim(str(prim.GetPath()), kind, IMPLICIT_TRIANGLES[kind], w.min(axis=0), w.max(axis=0), materials)
    if not exact:
        # The analytic surface bounds ours from outside: usd-core's extent (BBoxCache, from the
        # schema's extent plugin), and for a sphere its exact box centre +- r * |column k|.
        cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render], useExtentsHint=False)
        box = cache.ComputeWorldBound(prim).ComputeAlignedRange()
        record.outer_lo, record.outer_hi = np.array(box.GetMin()), np.array(box.GetMax())
        if kind == "Sphere":
            half = prim.GetAttribute("radius").Get(time) * np.linalg.norm(world[:3, :3], axis=0)
            record.outer_lo, record.outer_hi = world[3, :3] - half, world[3, :3] + half
    return record


def _gprim_record(prim: Usd.Prim, world: np.ndarray, time) -> Gprim | None:
    if prim.IsA(UsdGeom.Mesh):
        return _mesh_record(prim, world, time)
    if str(prim.GetTypeName()) in IMPLICIT_TRIANGLES and _implicit_valid(prim, time):
        return _shape_record(prim, world, time)
    return None


def _authored_token(attr: Usd.Attribute, time):
    return attr.Get(time) if attr.HasAuthoredValue() else None


class _Walker:
    """Collects the drawn gprims, lights and cameras of a stage."""

    def __init__(self, stage: Usd.Stage, time):
        self.stage = stage
        self.time = time
        self.predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
        self.out = Listing()
        # Prototype roots of every PointInstancer: drawn only through their instancer.
        self.prototypes = set()
        for prim in stage.Traverse(self.predicate):
            if prim.IsA(UsdGeom.PointInstancer):
                self.prototypes.update(UsdGeom.PointInstancer(prim).GetPrototypesRel().GetTargets())

    def world(self, prim) -> np.ndarray:
        return _matrix(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(self.time))

    def add_gprim(self, prim, world) -> None:
        record = _gprim_record(prim, world, self.time)
        if record is not None:
            self.out.gprims.append(record)

    def walk_stage(self) -> Listing:
        it = iter(Usd.PrimRange.Stage(self.stage, self.predicate))
        for prim in it:
            if prim.GetPath() in self.prototypes:
                it.PruneChildren()
                continue
            type_name = prim.GetTypeName()
            if type_name == "Camera":
                self.out.cameras += 1
            elif type_name in SUPPORTED_LIGHTS:
                self.out.lights += _drawn(prim, self.time)
            elif prim.IsA(UsdGeom.PointInstancer):
                if _drawn(prim, self.time):
                    purpose = UsdGeom.Imageable(prim).ComputePurpose()
                    self.expand_point_instancer(prim, self.world(prim), purpose)
            elif prim.IsA(UsdGeom.Gprim) and _drawn(prim, self.time):
                self.add_gprim(prim, self.world(prim))
        return self.out

    def expand_point_instancer(self, prim, instancer_world: np.ndarray, purpose: str) -> None:
        """Adds the gprims every visible instance of a PointInstancer draws."""
        pi = UsdGeom.PointInstancer(prim)
        prototypes = pi.GetPrototypesRel().GetTargets()
        indices = pi.GetProtoIndicesAttr().Get(self.time) or []
        if not len(indices):
            return
        # Instancer-space transform of each instance, including the prototype root's own transform.
        xforms = pi.ComputeInstanceTransformsAtTime(
            self.time, self.time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
        )
        # usd-core computes no transforms for an instancer whose protoIndices name a missing
        # prototype or whose positions are shorter than them: it draws nothing then.
        if len(xforms) != len(indices):
            return
        mask = pi.ComputeMaskAtTime(self.time)
        for i, proto_index in enumerate(indices):
            if (mask and not mask[i]) or not 0 <= proto_index < len(prototypes):
                continue
            proto = self.stage.GetPrimAtPath(prototypes[proto_index])
            # A prim below the prototype root: its world matrix times (root world)^-1 is its transform
            # relative to the root's local space; the instance transform then takes it to the
            # instancer's space.
            to_instance = np.linalg.inv(self.world(proto)) @ _matrix(xforms[i]) @ instancer_world
            self.walk_prototype(proto, to_instance, False, purpose, root=True)

    def walk_prototype(self, prim, to_instance, invisible: bool, purpose: str, root: bool = False) -> None:
        """Walks a prototype subtree with the inherited state of one PointInstancer instance."""
        if not root and prim.GetPath() in self.prototypes:
            return
        if prim.IsA(UsdGeom.Imageable):
            img = UsdGeom.Imageable(prim)
            if _authored_token(img.GetVisibilityAttr(), self.time) == UsdGeom.Tokens.invisible:
                invisible = True
            purpose = _authored_token(img.GetPurposeAttr(), self.time) or purpose
        drawn = not invisible and purpose in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
        if drawn and prim.IsA(UsdGeom.PointInstancer):
            self.expand_point_instancer(prim, self.world(prim) @ to_instance, purpose)
        elif drawn and prim.IsA(UsdGeom.Gprim):
            self.add_gprim(prim, self.world(prim) @ to_instance)
        for child in prim.GetFilteredChildren(self.predicate):
            self.walk_prototype(child, to_instance, invisible, purpose)


def usd_listing(path, time=None, load_payloads: bool = True) -> Listing:
    """Every gprim usd-core draws on the stage at `path`.

    `time`: None for `Usd.TimeCode.Default()`, "start" for the stage's startTimeCode, or a number.
    """
    stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll if load_payloads else Usd.Stage.LoadNone)
    assert stage, f"usd-core cannot open {path}"
    if time is None:
        time = Usd.TimeCode.Default()
    elif time == "start":
        time = Usd.TimeCode(stage.GetStartTimeCode())
    else:
        time = Usd.TimeCode(time)
    return _Walker(stage, time).walk_stage()


# --- comparison ----------------------------------------------------------------------------------


def ours_materials(entry) -> frozenset:
    """Our material paths for a dumped gprim, with the synthetic displayColor material as 'none'."""
    return frozenset(m for m in entry["materials"] if not m.endswith(".displayColor"))


def tolerance(listing: Listing) -> float:
    """Absolute bounds tolerance: 1e-5 of the scene's extent (at least 1e-5)."""
    lo, hi = listing.bounds()
    extent = 0.0 if lo is None else float(np.linalg.norm(hi - lo))
    return max(1.0, extent) * 1e-5


def _close(ours, ref, atol) -> bool:
    ours = np.asarray(ours, dtype=np.float64)
    # float32 storage of our positions: allow a few ulps of the value itself.
    return bool(np.all(np.abs(ours - ref) <= atol + 4 * F32_EPS * np.abs(ref)))


def expected_triangles(entry, g: Gprim) -> int | None:
    """The triangles `entry` must have: the cage's, or for a subdivision mesh the count at the
    level the ingest reports (None: not compared)."""
    if g.scheme is not None and "subdiv_level" in entry:
        if entry.get("subdiv_mode") == "adaptive":
            return None  # a range, checked in _entry_matches
        return g.subdiv_triangles(entry["subdiv_level"])
    return g.triangles


def _entry_matches(entry, g: Gprim, atol) -> list[str]:
    """Differences between one dumped gprim and one reference gprim (same path)."""
    problems = []
    subdivided = g.scheme is not None and "subdiv_level" in entry
    if subdivided and entry.get("scheme") != g.scheme:
        problems.append(f"scheme: ours {entry.get('scheme')}, usd-core {g.scheme}")
    want = expected_triangles(entry, g)
    if want is not None and entry["triangles"] != want:
        level = f" at subdiv_level {entry['subdiv_level']}" if subdivided else ""
        problems.append(f"triangles: ours {entry['triangles']}, usd-core {want}{level}")
    if subdivided and entry.get("subdiv_mode") == "adaptive":
        low, high = g.adaptive_triangle_range(entry["subdiv_level"])
        if not low <= entry["triangles"] <= high:
            problems.append(f"triangles: ours {entry['triangles']} (adaptive), usd-core {low}..{high}")
    if g.lo is not None:
        lo, hi = np.asarray(entry["bounds_min"]), np.asarray(entry["bounds_max"])
        if g.outer_lo is not None:
            ok = all(
                np.all(x >= a - atol - 4 * F32_EPS * np.abs(a)) and np.all(x <= b + atol + 4 * F32_EPS * np.abs(b))
                for x, a, b in ((lo, g.outer_lo, g.lo), (hi, g.hi, g.outer_hi))
            )
        else:
            ok = _close(lo, g.lo, atol) and _close(hi, g.hi, atol)
        if not ok:
            problems.append(
                f"bounds: ours {np.round(lo, 6).tolist()}..{np.round(hi, 6).tolist()}, "
                f"usd-core {np.round(g.lo, 6).tolist()}..{np.round(g.hi, 6).tolist()} (tolerance {atol:.3g})"
            )
    mats = ours_materials(entry)
    if mats != g.materials:
        problems.append(f"materials: ours {sorted(mats)}, usd-core {sorted(g.materials)}")
    return problems


def compare(dump: dict, ref: Listing) -> list[str]:
    """Every difference between an `ingest --dump-json` listing and the usd-core listing."""
    atol = tolerance(ref)
    ours_by_path = defaultdict(list)
    for entry in dump["gprims"]:
        ours_by_path[entry["path"]].append(entry)
    ref_by_path = defaultdict(list)
    for g in ref.gprims:
        ref_by_path[g.path].append(g)
    problems = []
    only_ours = sorted(set(ours_by_path) - set(ref_by_path))
    only_ref = sorted(set(ref_by_path) - set(ours_by_path))
    if only_ours:
        problems.append(f"gprims only in ours: {only_ours}")
    if only_ref:
        problems.append(f"gprims only in usd-core: {only_ref}")
    for path in sorted(set(ours_by_path) & set(ref_by_path)):
        ours, refs = ours_by_path[path], ref_by_path[path]
        if len(ours) != len(refs):
            problems.append(f"{path}: drawn {len(ours)} times by ours, {len(refs)} times by usd-core")
            continue
        # Instanced paths repeat: pair each reference gprim with any still unmatched entry.
        unmatched = list(ours)
        for g in refs:
            for entry in unmatched:
                if not _entry_matches(entry, g, atol):
                    unmatched.remove(entry)
                    break
            else:
                best = min(unmatched, key=lambda e: len(_entry_matches(e, g, atol)))
                problems.extend(f"{path}: {p}" for p in _entry_matches(best, g, atol))
                unmatched.remove(best)
    return problems
