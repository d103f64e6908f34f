// C ABI over OpenSubdiv's Far layer, consumed by `src/ffi.rs`.
//
// Contract with the Rust side:
// - Rust validates topology before calling in, so the checks here are a second line of defence.
// - Every entry point catches every C++ exception and returns a non-zero status; the message is kept
//   in a thread-local string readable through `osd_last_error`. No exception crosses the C ABI.
// - `NDEBUG` is defined by build.rs: the header-only templates below contain `assert`s, and an assert
//   would abort the host process instead of returning an error.
// - Primvar buffers are `double`: refinement through several levels accumulates rounding, and the
//   tests measure geometric properties (collinearity, convergence) at the 1e-6 scale.

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/bfr/tessellation.h>
#include <opensubdiv/far/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cmath>
#include <cstring>
#include <map>
#include <exception>
#include <memory>
#include <algorithm>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

using namespace OpenSubdiv;

namespace {

thread_local std::string g_last_error;
// Messages Far reports through its error callback while one of our calls runs on this thread.
thread_local std::string g_far_messages;
// Far errors (not warnings) reported during the current call.
thread_local int g_far_errors = 0;

void far_error_callback(Far::ErrorType err, const char *message) {
    if (!g_far_messages.empty()) g_far_messages += "; ";
    g_far_messages += message ? message : "(null)";
    ++g_far_errors;
    // Far's default handler exits the process on a fatal error; unwinding to our catch instead
    // turns it into an error status.
    if (err == Far::FAR_FATAL_ERROR) throw std::runtime_error(g_far_messages);
}

void far_warning_callback(const char *message) {
    if (!g_far_messages.empty()) g_far_messages += "; ";
    g_far_messages += "warning: ";
    g_far_messages += message ? message : "(null)";
}

void install_callbacks() {
    // The callbacks are process-global; installing them once avoids racing writes between threads.
    static std::once_flag once;
    std::call_once(once, [] {
        Far::SetErrorCallback(far_error_callback);
        Far::SetWarningCallback(far_warning_callback);
    });
}

// A row of `width` doubles inside a caller-owned buffer: the "vertex" type PrimvarRefiner expects
// (Clear + AddWithWeight), for primvars of any width.
struct Row {
    double *p;
    int width;
    void Clear() {
        for (int i = 0; i < width; ++i) p[i] = 0.0;
    }
    void AddWithWeight(Row const &src, double weight) {
        for (int i = 0; i < width; ++i) p[i] += weight * src.p[i];
    }
};

struct Rows {
    double *base;
    int width;
    Row operator[](int i) const { return Row{base + static_cast<size_t>(i) * width, width}; }
};

template <class F>
int guarded(F &&f) {
    g_far_messages.clear();
    g_far_errors = 0;
    try {
        install_callbacks();
        f();
        return 0;
    } catch (std::bad_alloc const &) {
        g_last_error = "out of memory in OpenSubdiv";
    } catch (std::exception const &e) {
        g_last_error = e.what();
    } catch (...) {
        g_last_error = "unknown C++ exception in OpenSubdiv";
    }
    return 1;
}

[[noreturn]] void fail(std::string what) {
    if (!g_far_messages.empty()) what += ": " + g_far_messages;
    throw std::runtime_error(what);
}

} // namespace

extern "C" {

struct OsdDesc {
    int scheme;               // Sdc::SchemeType
    int boundary;             // Sdc::Options::VtxBoundaryInterpolation
    int fvar_linear;          // Sdc::Options::FVarLinearInterpolation
    int triangle_subdivision; // Sdc::Options::TriangleSubdivision
    int num_vertices;
    int num_faces;
    const int *face_vertex_counts;
    const int *face_vertex_indices;
    int num_creases; // edges, i.e. pairs in crease_vertex_pairs
    const int *crease_vertex_pairs;
    const float *crease_sharpnesses;
    int num_corners;
    const int *corner_indices;
    const float *corner_sharpnesses;
    int num_holes;
    const int *hole_indices;
    int num_fvar_channels;
    const int *fvar_value_counts;           // one per channel
    const int *const *fvar_value_indices;   // one array per channel, face-vertex sized
    int level;
};

struct OsdRefiner {
    Far::TopologyRefiner *refiner = nullptr;
    ~OsdRefiner() { delete refiner; }
};

const char *osd_last_error(void) { return g_last_error.c_str(); }

int osd_refiner_new(const OsdDesc *d, OsdRefiner **out) {
    *out = nullptr;
    return guarded([&] {
        std::vector<Far::TopologyDescriptor::FVarChannel> channels(d->num_fvar_channels);
        for (int c = 0; c < d->num_fvar_channels; ++c) {
            channels[c].numValues = d->fvar_value_counts[c];
            channels[c].valueIndices = d->fvar_value_indices[c];
        }

        Far::TopologyDescriptor desc;
        desc.numVertices = d->num_vertices;
        desc.numFaces = d->num_faces;
        desc.numVertsPerFace = d->face_vertex_counts;
        desc.vertIndicesPerFace = d->face_vertex_indices;
        desc.numCreases = d->num_creases;
        desc.creaseVertexIndexPairs = d->crease_vertex_pairs;
        desc.creaseWeights = d->crease_sharpnesses;
        desc.numCorners = d->num_corners;
        desc.cornerVertexIndices = d->corner_indices;
        desc.cornerWeights = d->corner_sharpnesses;
        desc.numHoles = d->num_holes;
        desc.holeIndices = d->hole_indices;
        desc.numFVarChannels = d->num_fvar_channels;
        desc.fvarChannels = channels.empty() ? nullptr : channels.data();

        Sdc::Options sdc;
        sdc.SetVtxBoundaryInterpolation(static_cast<Sdc::Options::VtxBoundaryInterpolation>(d->boundary));
        sdc.SetFVarLinearInterpolation(static_cast<Sdc::Options::FVarLinearInterpolation>(d->fvar_linear));
        sdc.SetTriangleSubdivision(static_cast<Sdc::Options::TriangleSubdivision>(d->triangle_subdivision));
        sdc.SetCreasingMethod(Sdc::Options::CREASE_UNIFORM);

        using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
        Factory::Options options(static_cast<Sdc::SchemeType>(d->scheme), sdc);
        Far::TopologyRefiner *refiner = Factory::Create(desc, options);
        if (!refiner) fail("OpenSubdiv rejected the topology");

        auto holder = new OsdRefiner();
        holder->refiner = refiner;
        if (d->level > 0) {
            Far::TopologyRefiner::UniformOptions uniform(d->level);
            // Limit() needs vertex-edge and vertex-face relations in the last level.
            uniform.fullTopologyInLastLevel = true;
            try {
                refiner->RefineUniform(uniform);
            } catch (...) {
                delete holder;
                throw;
            }
        }
        *out = holder;
    });
}

void osd_refiner_free(OsdRefiner *r) { delete r; }

// Counts at the last level: vertices, faces, face-vertices, and fvar values of `channel` (or 0).
int osd_refiner_counts(const OsdRefiner *r, int channel, int *num_vertices, int *num_faces,
                       int *num_face_vertices, int *num_fvar_values) {
    return guarded([&] {
        auto const &level = r->refiner->GetLevel(r->refiner->GetMaxLevel());
        *num_vertices = level.GetNumVertices();
        *num_faces = level.GetNumFaces();
        *num_face_vertices = level.GetNumFaceVertices();
        *num_fvar_values = channel >= 0 ? level.GetNumFVarValues(channel) : 0;
    });
}

// Faces of the last level. `fvar_values` (may be null) receives the face-vertex values of `channel`;
// `coarse_face` the level-0 ancestor of each face; `is_hole` 1 for faces in holes (including the
// boundary faces Sdc tags as holes under VTX_BOUNDARY_NONE).
int osd_refiner_faces(const OsdRefiner *r, int channel, int *counts, int *vertices, int *fvar_values,
                      int *coarse_face, unsigned char *is_hole) {
    return guarded([&] {
        Far::TopologyRefiner const &tr = *r->refiner;
        int max_level = tr.GetMaxLevel();

        std::vector<int> ancestor(tr.GetLevel(0).GetNumFaces());
        for (size_t f = 0; f < ancestor.size(); ++f) ancestor[f] = static_cast<int>(f);
        for (int l = 1; l <= max_level; ++l) {
            auto const &level = tr.GetLevel(l);
            std::vector<int> next(level.GetNumFaces());
            for (int f = 0; f < level.GetNumFaces(); ++f) next[f] = ancestor[level.GetFaceParentFace(f)];
            ancestor.swap(next);
        }

        auto const &level = tr.GetLevel(max_level);
        size_t k = 0;
        for (int f = 0; f < level.GetNumFaces(); ++f) {
            auto fv = level.GetFaceVertices(f);
            counts[f] = fv.size();
            coarse_face[f] = ancestor[f];
            is_hole[f] = level.IsFaceHole(f) ? 1 : 0;
            for (int i = 0; i < fv.size(); ++i) vertices[k + i] = fv[i];
            if (fvar_values) {
                auto values = level.GetFaceFVarValues(f, channel);
                for (int i = 0; i < values.size(); ++i) fvar_values[k + i] = values[i];
            }
            k += fv.size();
        }
    });
}

// Refines level-0 vertex data (`width` doubles per vertex) to the last level. With `limit` set the
// refined values are then projected to the limit surface; `du`/`dv` (may be null, only with `limit`)
// receive the limit tangents.
int osd_refine_vertex(const OsdRefiner *r, const double *src, int width, int limit, double *dst,
                      double *du, double *dv) {
    return guarded([&] {
        Far::TopologyRefiner const &tr = *r->refiner;
        Far::PrimvarRefinerReal<double> primvar(tr);
        int max_level = tr.GetMaxLevel();

        std::vector<double> cur(src, src + static_cast<size_t>(tr.GetLevel(0).GetNumVertices()) * width);
        std::vector<double> next;
        for (int l = 1; l <= max_level; ++l) {
            next.assign(static_cast<size_t>(tr.GetLevel(l).GetNumVertices()) * width, 0.0);
            Rows s{cur.data(), width}, d{next.data(), width};
            primvar.Interpolate(l, s, d);
            cur.swap(next);
        }

        Rows s{cur.data(), width}, d{dst, width};
        if (!limit) {
            std::memcpy(dst, cur.data(), cur.size() * sizeof(double));
        } else if (du && dv) {
            Rows t1{du, width}, t2{dv, width};
            primvar.Limit(s, d, t1, t2);
        } else {
            primvar.Limit(s, d);
        }
        if (g_far_errors) fail("PrimvarRefiner failed");
    });
}

// Face-varying counterpart of `osd_refine_vertex` for one channel.
int osd_refine_fvar(const OsdRefiner *r, int channel, const double *src, int width, int limit,
                    double *dst) {
    return guarded([&] {
        Far::TopologyRefiner const &tr = *r->refiner;
        Far::PrimvarRefinerReal<double> primvar(tr);
        int max_level = tr.GetMaxLevel();

        std::vector<double> cur(src,
                                src + static_cast<size_t>(tr.GetLevel(0).GetNumFVarValues(channel)) * width);
        std::vector<double> next;
        for (int l = 1; l <= max_level; ++l) {
            next.assign(static_cast<size_t>(tr.GetLevel(l).GetNumFVarValues(channel)) * width, 0.0);
            Rows s{cur.data(), width}, d{next.data(), width};
            primvar.InterpolateFaceVarying(l, s, d, channel);
            cur.swap(next);
        }

        // An unrefined refiner (level 0) has no face-varying crease topology for the limit masks:
        // LimitFaceVarying dereferences it and crashes (seen on testUsdImagingGLFaceVaryingLinearInterp).
        // The cage values are what level 0 shows, so they are returned as they are.
        if (!limit || max_level == 0) {
            std::memcpy(dst, cur.data(), cur.size() * sizeof(double));
        } else {
            Rows s{cur.data(), width}, d{dst, width};
            primvar.LimitFaceVarying(s, d, channel);
        }
        if (g_far_errors) fail("PrimvarRefiner failed");
    });
}

} // extern "C"

// ---------------------------------------------------------------------------------------------
// Per-face tessellation through Bfr (limit surface evaluation of each base face).
//
// The refiner passed in must be unrefined (level 0): Bfr builds each face's limit surface from the
// base level. Rates are given per base edge, so the two faces of an edge always agree on its
// points; the points on an edge (and at a vertex) are evaluated once, by the first face that
// reaches them, and every later face refers to the same point. That is what makes the result
// watertight with bit-identical positions, not the (nearly equal) evaluations of two patches.

namespace {

using Factory = Bfr::RefinerSurfaceFactory<>;

// Bfr represents the limit surface near an extraordinary vertex by refining towards it this many
// times and closing the rest with a Gregory patch, which is an approximation. Bfr's default (2)
// leaves up to 2.6e-3 of the size between its points and the exact limit points on a cube cage
// (every face touches a valence-3 corner); 4 leaves 4.4e-4 (adaptive_tests.rs measures it). The
// cost is paid only by faces with an extraordinary vertex.
constexpr int kApproxLevelSmooth = 4;

Factory::Options factory_options_for_accuracy() {
    Factory::Options options;
    options.SetApproxLevelSmooth(kApproxLevelSmooth);
    return options;
}

// Facets with a 4th index of -1 are triangles (Tessellation pads them when facet size is 4).
constexpr int kFacetSize = 4;

// The Bfr::Tessellation rates of base face `f`: its edges' rates, then the interior rates (the
// maxima of opposite edges for a quad, of all edges otherwise).
void face_rates(Far::TopologyLevel const &base, int f, const int *edge_rates, std::vector<int> &rates) {
    auto fe = base.GetFaceEdges(f);
    int const n = fe.size();
    rates.assign(n, 1);
    for (int i = 0; i < n; ++i) rates[i] = edge_rates[fe[i]];
    if (n == 4) {
        rates.push_back(std::max(rates[0], rates[2]));
        rates.push_back(std::max(rates[1], rates[3]));
    } else {
        rates.push_back(*std::max_element(rates.begin(), rates.end()));
    }
}

Bfr::Tessellation::Options tessellation_options() {
    Bfr::Tessellation::Options options;
    options.SetFacetSize(kFacetSize);
    options.PreserveQuads(true);
    return options;
}

} // namespace

extern "C" {

struct OsdAdaptive {
    int width = 0;      // doubles per vertex in `data`, `du`, `dv`
    int fvar_width = 0; // doubles per vertex in `fvar` (0 without a channel)
    std::vector<double> data, du, dv, fvar;
    std::vector<int> triangles;       // 3 per triangle, output vertex indices
    std::vector<int> coarse_face;     // one per triangle
    std::vector<float> corner_coords; // 6 per triangle: (u, v) of each corner in its face, if asked
};

// Number of base edges.
int osd_base_edge_count(const OsdRefiner *r, int *num_edges) {
    return guarded([&] { *num_edges = r->refiner->GetLevel(0).GetNumEdges(); });
}

// Base edges as vertex pairs (2 per edge) and the edges of each face, in face-vertex order (edge i
// of a face runs from its vertex i to vertex i + 1), concatenated like the face-vertex indices.
int osd_base_edges(const OsdRefiner *r, int *edge_vertices, int *face_edges) {
    return guarded([&] {
        auto const &base = r->refiner->GetLevel(0);
        for (int e = 0; e < base.GetNumEdges(); ++e) {
            auto ev = base.GetEdgeVertices(e);
            edge_vertices[2 * e] = ev[0];
            edge_vertices[2 * e + 1] = ev[1];
        }
        size_t k = 0;
        for (int f = 0; f < base.GetNumFaces(); ++f) {
            auto fe = base.GetFaceEdges(f);
            for (int i = 0; i < fe.size(); ++i) face_edges[k++] = fe[i];
        }
    });
}

// Tessellates every base face with a limit surface. `vertex_data` holds `width` (≥ 3) doubles per
// base vertex, positions first; all of them are evaluated on the vertex surface, with first
// derivatives. With `channel` ≥ 0, `fvar_data` holds `fvar_width` doubles per value of that
// face-varying channel, evaluated on the face-varying surface; output vertices are then split
// where two faces sharing a point use different face-varying values (seams). `edge_rates` has one
// rate (≥ 1) per base edge; the interior rates of a face are the maxima of its opposite edges
// (quads) or of all its edges. With `want_coords`, the (u, v) of each triangle corner in its
// face's parameterization are kept (for error measurements).
int osd_tessellate_adaptive(const OsdRefiner *r, const double *vertex_data, int width, int channel,
                            const double *fvar_data, int fvar_width, const int *edge_rates,
                            int want_coords, OsdAdaptive **out) {
    *out = nullptr;
    return guarded([&] {
        Far::TopologyRefiner const &tr = *r->refiner;
        auto const &base = tr.GetLevel(0);
        bool const fvar = channel >= 0;

        Factory::Options factory_options = factory_options_for_accuracy();
        if (fvar) factory_options.SetDefaultFVarID(channel);
        Factory factory(tr, factory_options);

        std::unique_ptr<OsdAdaptive> result(new OsdAdaptive());
        OsdAdaptive &res = *result;
        res.width = width;
        res.fvar_width = fvar ? fvar_width : 0;

        // Geometry points (position and derivatives), shared by vertex and edge. Without a
        // face-varying channel an output vertex is a point; with one, each point has a chain of
        // output vertices, one per distinct (face-varying value pair) that reaches it.
        std::vector<int> vertex_point(base.GetNumVertices(), -1);
        std::vector<int> edge_point(base.GetNumEdges(), -1);
        std::vector<double> point_data, point_du, point_dv;
        struct OutVertex {
            int point, fa, fb, next;
        };
        std::vector<OutVertex> out_vertices;
        std::vector<int> first_out; // per point: head of its chain of output vertices

        Bfr::Surface<double> vsurf, fsurf;
        std::vector<double> vpatch, fpatch, coords;
        std::vector<int> local_to_out, facets, rates;
        std::vector<double> uv_tmp(fvar ? fvar_width : 0);
        Bfr::Tessellation::Options const tess_options = tessellation_options();

        auto new_point = [&](double const *uv) -> int {
            int p = static_cast<int>(point_data.size() / width);
            point_data.resize(point_data.size() + width);
            point_du.resize(point_du.size() + width);
            point_dv.resize(point_dv.size() + width);
            vsurf.Evaluate(uv, vpatch.data(), width, &point_data[size_t(p) * width], &point_du[size_t(p) * width],
                           &point_dv[size_t(p) * width]);
            first_out.push_back(-1);
            return p;
        };
        // The output vertex of `point` on the side of face-varying values (fa, fb), created with
        // the face-varying value evaluated at `uv` of the current face if it does not exist yet.
        auto out_of = [&](int point, int fa, int fb, double const *uv) -> int {
            if (!fvar) return point;
            for (int o = first_out[point]; o >= 0; o = out_vertices[o].next) {
                if (out_vertices[o].fa == fa && out_vertices[o].fb == fb) return o;
            }
            int o = static_cast<int>(out_vertices.size());
            out_vertices.push_back({point, fa, fb, first_out[point]});
            first_out[point] = o;
            fsurf.Evaluate(uv, fpatch.data(), fvar_width, uv_tmp.data());
            res.fvar.insert(res.fvar.end(), uv_tmp.begin(), uv_tmp.end());
            return o;
        };
        Bfr::Surface<double>::PointDescriptor vdesc(width);
        Bfr::Surface<double>::PointDescriptor fdesc(fvar ? fvar_width : 1);
        Factory::FVarID const fvar_id = channel;

        for (int f = 0; f < base.GetNumFaces(); ++f) {
            if (!factory.FaceHasLimitSurface(f)) continue; // holes, and faces interpolateBoundary drops
            bool ok = fvar ? factory.InitSurfaces(f, &vsurf, &fsurf, &fvar_id, 1)
                           : factory.InitVertexSurface(f, &vsurf);
            if (!ok) fail("cannot build the limit surface of face " + std::to_string(f));
            vpatch.resize(size_t(vsurf.GetNumPatchPoints()) * width);
            vsurf.PreparePatchPoints(vertex_data, vdesc, vpatch.data(), vdesc);
            if (fvar) {
                fpatch.resize(size_t(fsurf.GetNumPatchPoints()) * fvar_width);
                fsurf.PreparePatchPoints(fvar_data, fdesc, fpatch.data(), fdesc);
            }

            auto fv = base.GetFaceVertices(f);
            auto fe = base.GetFaceEdges(f);
            int const n = fv.size();
            face_rates(base, f, edge_rates, rates);
            Bfr::Tessellation tess(vsurf.GetParameterization(), static_cast<int>(rates.size()), rates.data(),
                                   tess_options);
            if (!tess.IsValid()) fail("invalid tessellation rates on face " + std::to_string(f));
            int const num_coords = tess.GetNumCoords();
            coords.resize(size_t(num_coords) * 2);
            tess.GetCoords(coords.data());
            local_to_out.assign(num_coords, -1);

            // Walk the boundary: corner i, then the points inside edge i.
            int b = 0;
            for (int i = 0; i < n; ++i) {
                int const v = fv[i], w = fv[(i + 1) % n];
                int const va = fvar ? base.GetFaceFVarValues(f, channel)[i] : -1;
                int const wa = fvar ? base.GetFaceFVarValues(f, channel)[(i + 1) % n] : -1;
                int &vp = vertex_point[v];
                if (vp < 0) vp = new_point(&coords[2 * b]);
                local_to_out[b] = out_of(vp, va, -1, &coords[2 * b]);
                ++b;

                int const inner = rates[i] - 1;
                if (inner <= 0) continue;
                auto ev = base.GetEdgeVertices(fe[i]);
                bool const forward = ev[0] == v && ev[1] == w;
                int &ep = edge_point[fe[i]];
                if (ep < 0) {
                    // Points are stored in the edge's own direction (ev[0] → ev[1]).
                    ep = static_cast<int>(point_data.size() / width);
                    for (int j = 0; j < inner; ++j) {
                        int const local = b + (forward ? j : inner - 1 - j);
                        new_point(&coords[2 * local]);
                    }
                }
                int const fa = forward ? va : wa, fb = forward ? wa : va;
                for (int j = 0; j < inner; ++j, ++b) {
                    int const point = ep + (forward ? j : inner - 1 - j);
                    local_to_out[b] = out_of(point, fa, fb, &coords[2 * b]);
                }
            }
            if (b != tess.GetNumBoundaryCoords()) fail("unexpected boundary of face " + std::to_string(f));
            for (int c = b; c < num_coords; ++c) {
                int const point = new_point(&coords[2 * c]);
                local_to_out[c] = out_of(point, -2, -2, &coords[2 * c]);
            }

            facets.resize(size_t(tess.GetNumFacets()) * kFacetSize);
            tess.GetFacets(facets.data());
            auto position = [&](int local) {
                int o = local_to_out[local];
                int p = fvar ? out_vertices[o].point : o;
                return &point_data[size_t(p) * width];
            };
            auto emit = [&](int a, int b2, int c) {
                res.triangles.insert(res.triangles.end(), {local_to_out[a], local_to_out[b2], local_to_out[c]});
                res.coarse_face.push_back(f);
                if (want_coords) {
                    for (int k : {a, b2, c}) {
                        res.corner_coords.push_back(static_cast<float>(coords[2 * k]));
                        res.corner_coords.push_back(static_cast<float>(coords[2 * k + 1]));
                    }
                }
            };
            auto dist2 = [&](int a, int c) {
                double const *p = position(a), *q = position(c);
                return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
            };
            for (size_t k = 0; k < facets.size(); k += kFacetSize) {
                int const *q = &facets[k];
                if (q[3] < 0) {
                    emit(q[0], q[1], q[2]);
                } else if (dist2(q[0], q[2]) <= dist2(q[1], q[3])) {
                    // Quads split along the shorter diagonal, as the uniform path does.
                    emit(q[0], q[1], q[2]);
                    emit(q[0], q[2], q[3]);
                } else {
                    emit(q[0], q[1], q[3]);
                    emit(q[1], q[2], q[3]);
                }
            }
        }
        if (g_far_errors) fail("Bfr failed");

        // Output vertices: points (no face-varying channel) or the chain entries.
        if (!fvar) {
            res.data.swap(point_data);
            res.du.swap(point_du);
            res.dv.swap(point_dv);
        } else {
            size_t const count = out_vertices.size();
            res.data.resize(count * width);
            res.du.resize(count * width);
            res.dv.resize(count * width);
            for (size_t o = 0; o < count; ++o) {
                size_t const p = size_t(out_vertices[o].point) * width;
                std::copy(&point_data[p], &point_data[p] + width, &res.data[o * width]);
                std::copy(&point_du[p], &point_du[p] + width, &res.du[o * width]);
                std::copy(&point_dv[p], &point_dv[p] + width, &res.dv[o * width]);
            }
        }
        *out = result.release();
    });
}

// Triangles `osd_tessellate_adaptive` makes of each base face at `edge_rates` (0 for a face without
// a limit surface), counted from the facets of the same Bfr::Tessellation without building or
// evaluating any surface: the tessellation pattern depends only on the face's parameterization
// (scheme and size) and its rates, so each distinct pattern is tessellated once.
int osd_plan_adaptive(const OsdRefiner *r, const int *edge_rates, long long *face_triangles) {
    return guarded([&] {
        Far::TopologyRefiner const &tr = *r->refiner;
        auto const &base = tr.GetLevel(0);
        Factory factory(tr, factory_options_for_accuracy());
        Bfr::Tessellation::Options const tess_options = tessellation_options();
        std::map<std::vector<int>, long long> triangles_of_pattern;
        std::vector<int> rates, facets;
        for (int f = 0; f < base.GetNumFaces(); ++f) {
            if (!factory.FaceHasLimitSurface(f)) {
                face_triangles[f] = 0;
                continue;
            }
            face_rates(base, f, edge_rates, rates);
            rates.push_back(base.GetFaceVertices(f).size()); // the key: rates and face size
            auto known = triangles_of_pattern.find(rates);
            if (known != triangles_of_pattern.end()) {
                face_triangles[f] = known->second;
                continue;
            }
            Bfr::Tessellation tess(factory.GetFaceParameterization(f), static_cast<int>(rates.size()) - 1,
                                   rates.data(), tess_options);
            if (!tess.IsValid()) fail("invalid tessellation rates on face " + std::to_string(f));
            facets.resize(size_t(tess.GetNumFacets()) * kFacetSize);
            tess.GetFacets(facets.data());
            long long count = 0;
            for (size_t k = 0; k < facets.size(); k += kFacetSize) count += facets[k + 3] < 0 ? 1 : 2;
            triangles_of_pattern.emplace(rates, count);
            face_triangles[f] = count;
        }
        if (g_far_errors) fail("Bfr failed");
    });
}

// Per base face, 1 if it has no surface: listed in holeIndices, or a boundary face that
// interpolateBoundary = none drops (Far tags both as holes; refined faces inherit the tag).
int osd_base_face_holes(const OsdRefiner *r, unsigned char *is_hole) {
    return guarded([&] {
        auto const &base = r->refiner->GetLevel(0);
        for (int f = 0; f < base.GetNumFaces(); ++f) is_hole[f] = base.IsFaceHole(f) ? 1 : 0;
    });
}

void osd_adaptive_free(OsdAdaptive *a) { delete a; }

// Sizes of a tessellation: output vertices and triangles.
void osd_adaptive_counts(const OsdAdaptive *a, int *num_vertices, int *num_triangles) {
    *num_vertices = static_cast<int>(a->data.size() / a->width);
    *num_triangles = static_cast<int>(a->coarse_face.size());
}

// Copies a tessellation out: `data`, `du`, `dv` (width per vertex), `fvar` (fvar_width per vertex,
// may be null), `triangles` (3 per triangle), `coarse_face`, `corner_coords` (6 per triangle, may be
// null; zeros unless asked for at tessellation).
void osd_adaptive_copy(const OsdAdaptive *a, double *data, double *du, double *dv, double *fvar, int *triangles,
                       int *coarse_face, float *corner_coords) {
    std::copy(a->data.begin(), a->data.end(), data);
    std::copy(a->du.begin(), a->du.end(), du);
    std::copy(a->dv.begin(), a->dv.end(), dv);
    if (fvar) std::copy(a->fvar.begin(), a->fvar.end(), fvar);
    std::copy(a->triangles.begin(), a->triangles.end(), triangles);
    std::copy(a->coarse_face.begin(), a->coarse_face.end(), coarse_face);
    if (corner_coords) {
        std::fill(corner_coords, corner_coords + a->coarse_face.size() * 6, 0.0f);
        std::copy(a->corner_coords.begin(), a->corner_coords.end(), corner_coords);
    }
}

// Limit positions (`width` doubles, from `vertex_data` as in osd_tessellate_adaptive) at `count`
// samples: face `faces[i]` at (u, v) = `coords[2i], coords[2i+1]`. A face without a limit surface
// is an error. Samples of the same face should be consecutive (the surface is rebuilt per run).
int osd_evaluate_limit(const OsdRefiner *r, const double *vertex_data, int width, int count, const int *faces,
                       const double *coords, double *out) {
    return guarded([&] {
        Factory factory(*r->refiner, factory_options_for_accuracy());
        Bfr::Surface<double> surf;
        Bfr::Surface<double>::PointDescriptor desc(width);
        std::vector<double> patch;
        int current = -1;
        for (int i = 0; i < count; ++i) {
            if (faces[i] != current) {
                current = faces[i];
                if (current < 0 || current >= factory.GetNumFaces() || !factory.InitVertexSurface(current, &surf))
                    fail("face " + std::to_string(current) + " has no limit surface");
                patch.resize(size_t(surf.GetNumPatchPoints()) * width);
                surf.PreparePatchPoints(vertex_data, desc, patch.data(), desc);
            }
            surf.Evaluate(&coords[2 * i], patch.data(), desc, &out[size_t(i) * width]);
        }
        if (g_far_errors) fail("Bfr failed");
    });
}

} // extern "C"
