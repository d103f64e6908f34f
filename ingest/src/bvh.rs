//! BVH build (being written).
