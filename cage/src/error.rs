//! The error type of cage validation and of `subdiv`'s refinement (one type for both).

/// Why a cage could not be subdivided or a primvar could not be refined.
///
/// Validation errors name the USD attribute at fault so that ingest can report it beside the prim
/// path and layer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The cage has no faces.
    #[error("faceVertexCounts is empty: a subdivision surface needs at least one face")]
    NoFaces,
    /// A face with fewer than three vertices.
    #[error("faceVertexCounts[{face}] = {count}: faces need at least 3 vertices")]
    DegenerateFace {
        /// Index of the face.
        face: usize,
        /// Its vertex count as authored.
        count: i64,
    },
    /// `faceVertexCounts` does not add up to the length of `faceVertexIndices`.
    #[error("faceVertexCounts sum to {sum} but faceVertexIndices has {len} entries")]
    CountMismatch {
        /// Sum of the face vertex counts.
        sum: u64,
        /// Length of the face vertex index array.
        len: usize,
    },
    /// An index outside its valid range.
    #[error("{attribute}[{at}] = {index} is outside 0..{bound}")]
    IndexOutOfRange {
        /// USD attribute holding the index, e.g. `faceVertexIndices`.
        attribute: &'static str,
        /// Position in that array.
        at: usize,
        /// The offending value.
        index: i64,
        /// Exclusive upper bound.
        bound: usize,
    },
    /// An attribute that is malformed in some other way (lengths that disagree, a crease along
    /// an edge the mesh does not have, a non-finite sharpness, …).
    #[error("{attribute}: {reason}")]
    Invalid {
        /// USD attribute at fault.
        attribute: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The requested refinement level is above `subdiv::MAX_LEVEL` or would overflow
    /// OpenSubdiv's 32-bit indices.
    #[error("refinement level {level} is too high for this cage (limit {max})")]
    LevelTooHigh {
        /// The requested level.
        level: u32,
        /// The highest level allowed for this cage.
        max: u32,
    },
    /// A primvar buffer whose length does not match the topology.
    #[error("{what}: expected {expected} values, got {got}")]
    PrimvarSize {
        /// Which buffer.
        what: &'static str,
        /// Expected number of scalars.
        expected: usize,
        /// Number of scalars passed.
        got: usize,
    },
    /// OpenSubdiv itself reported an error (or threw); the message is OpenSubdiv's.
    #[error("OpenSubdiv: {0}")]
    OpenSubdiv(String),
}

/// Shorthand used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
