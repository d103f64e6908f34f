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

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cstring>
#include <exception>
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
