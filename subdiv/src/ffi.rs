//! Raw declarations of the C ABI in `shim/osd_shim.cpp`. Private: the safe wrappers live in
//! [`crate::refine`] and [`crate::limit`].
//!
//! Every function returns 0 on success and non-zero after catching a C++ exception or a Far
//! error; the message is then available from [`osd_last_error`] on the same thread.

use std::ffi::{c_char, c_int, CStr};

/// Mirrors `OsdDesc`. Pointers borrow Rust slices for the duration of `osd_refiner_new` only.
#[repr(C)]
pub(crate) struct OsdDesc {
    pub scheme: c_int,
    pub boundary: c_int,
    pub fvar_linear: c_int,
    pub triangle_subdivision: c_int,
    pub num_vertices: c_int,
    pub num_faces: c_int,
    pub face_vertex_counts: *const c_int,
    pub face_vertex_indices: *const c_int,
    pub num_creases: c_int,
    pub crease_vertex_pairs: *const c_int,
    pub crease_sharpnesses: *const f32,
    pub num_corners: c_int,
    pub corner_indices: *const c_int,
    pub corner_sharpnesses: *const f32,
    pub num_holes: c_int,
    pub hole_indices: *const c_int,
    pub num_fvar_channels: c_int,
    pub fvar_value_counts: *const c_int,
    pub fvar_value_indices: *const *const c_int,
    pub level: c_int,
}

/// Opaque owner of a `Far::TopologyRefiner`.
#[repr(C)]
pub(crate) struct OsdRefiner {
    _private: [u8; 0],
}

/// Opaque owner of one per-face (Bfr) tessellation's output buffers.
#[repr(C)]
pub(crate) struct OsdAdaptive {
    _private: [u8; 0],
}

extern "C" {
    pub(crate) fn osd_last_error() -> *const c_char;
    pub(crate) fn osd_refiner_new(desc: *const OsdDesc, out: *mut *mut OsdRefiner) -> c_int;
    pub(crate) fn osd_refiner_free(r: *mut OsdRefiner);
    pub(crate) fn osd_refiner_counts(
        r: *const OsdRefiner,
        channel: c_int,
        num_vertices: *mut c_int,
        num_faces: *mut c_int,
        num_face_vertices: *mut c_int,
        num_fvar_values: *mut c_int,
    ) -> c_int;
    pub(crate) fn osd_refiner_faces(
        r: *const OsdRefiner,
        channel: c_int,
        counts: *mut c_int,
        vertices: *mut c_int,
        fvar_values: *mut c_int,
        coarse_face: *mut c_int,
        is_hole: *mut u8,
    ) -> c_int;
    pub(crate) fn osd_refine_vertex(
        r: *const OsdRefiner,
        src: *const f64,
        width: c_int,
        limit: c_int,
        dst: *mut f64,
        du: *mut f64,
        dv: *mut f64,
    ) -> c_int;
    pub(crate) fn osd_refine_fvar(
        r: *const OsdRefiner,
        channel: c_int,
        src: *const f64,
        width: c_int,
        limit: c_int,
        dst: *mut f64,
    ) -> c_int;
    pub(crate) fn osd_base_edge_count(r: *const OsdRefiner, num_edges: *mut c_int) -> c_int;
    pub(crate) fn osd_base_edges(
        r: *const OsdRefiner,
        edge_vertices: *mut c_int,
        face_edges: *mut c_int,
    ) -> c_int;
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn osd_tessellate_adaptive(
        r: *const OsdRefiner,
        vertex_data: *const f64,
        width: c_int,
        channel: c_int,
        fvar_data: *const f64,
        fvar_width: c_int,
        edge_rates: *const c_int,
        want_coords: c_int,
        out: *mut *mut OsdAdaptive,
    ) -> c_int;
    pub(crate) fn osd_plan_adaptive(
        r: *const OsdRefiner,
        edge_rates: *const c_int,
        face_triangles: *mut i64,
    ) -> c_int;
    pub(crate) fn osd_base_face_holes(r: *const OsdRefiner, is_hole: *mut u8) -> c_int;
    pub(crate) fn osd_adaptive_free(a: *mut OsdAdaptive);
    pub(crate) fn osd_adaptive_counts(
        a: *const OsdAdaptive,
        num_vertices: *mut c_int,
        num_triangles: *mut c_int,
    );
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn osd_adaptive_copy(
        a: *const OsdAdaptive,
        data: *mut f64,
        du: *mut f64,
        dv: *mut f64,
        fvar: *mut f64,
        triangles: *mut c_int,
        coarse_face: *mut c_int,
        corner_coords: *mut f32,
    );
    pub(crate) fn osd_evaluate_limit(
        r: *const OsdRefiner,
        vertex_data: *const f64,
        width: c_int,
        count: c_int,
        faces: *const c_int,
        coords: *const f64,
        out: *mut f64,
    ) -> c_int;
}

/// The message of the last failed shim call on this thread.
pub(crate) fn last_error() -> String {
    // SAFETY: the shim returns a pointer into a thread-local std::string that lives until the next
    // shim call on this thread; it is NUL-terminated and copied out before returning.
    unsafe { CStr::from_ptr(osd_last_error()) }.to_string_lossy().into_owned()
}
