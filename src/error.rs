//! The one error type of kdbeam.

use std::path::PathBuf;

use kdbeam_kernels::lanes::IsaError;
use kdbeam_kernels::Isa;

/// Everything that can go wrong with user input. Nothing in kdbeam panics on bad input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A file is not valid OBJ (or not valid gzip).
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the fault, 0 when it is not tied to a line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite {
        /// 0-based vertex index.
        vertex: usize,
        /// Its coordinates.
        position: [f32; 3],
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        /// 0-based face (triangle) index.
        face: usize,
        /// The index it holds.
        index: u64,
        /// How many vertices there are.
        vertex_count: usize,
    },
    /// A file holds no triangles.
    #[error("{}: no triangles", path.display())]
    NoTriangles {
        /// The file.
        path: PathBuf,
    },
    /// An index list whose length is not a multiple of 3, or too many vertices for `u32` indices.
    #[error("malformed mesh input: {0}")]
    MalformedMesh(String),
    /// A parameter outside its range.
    #[error("invalid {name}: {message}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its range, and what was given.
        message: String,
    },
    /// An ISA was forced that this CPU does not run.
    #[error("the {0} instruction set is not available on this CPU")]
    IsaUnavailable(Isa),
    /// A scene was given a geometry id it never issued, or one that was removed.
    #[error("geometry {0} is not in the scene (never added, or removed)")]
    UnknownGeometry(u32),
    /// A scene was given an instance id it never issued, or one that was removed.
    #[error("instance {0} is not in the scene (never added, or removed)")]
    UnknownInstance(u32),
    /// A transform with a NaN or infinite entry, or one that cannot be inverted.
    #[error("invalid transform: {0}")]
    InvalidTransform(String),
    /// New positions for a mesh whose vertex count they do not match (an update keeps the
    /// topology).
    #[error("geometry {geometry} has {expected} vertices, the update gives {given}")]
    VertexCountChanged {
        /// The geometry.
        geometry: u32,
        /// Its vertex count.
        expected: usize,
        /// The update's.
        given: usize,
    },
    /// A geometry that instances still use cannot be removed.
    #[error("geometry {geometry} is used by {instances} instance(s); remove them first")]
    GeometryInUse {
        /// The geometry.
        geometry: u32,
        /// How many instances use it.
        instances: usize,
    },
    /// A scene has issued every id of 32 bits but the invalid one (ids are never reused).
    #[error("the scene has used up its {0} ids")]
    IdsExhausted(&'static str),
    /// A scene was traced before its first `commit()`.
    #[error("the scene was never committed")]
    NotCommitted,
    /// `builtin:NAME` names no built-in scene.
    #[error("unknown built-in scene {0:?} (try builtin:default, builtin:icosphere, builtin:grid, builtin:soup, builtin:hair, builtin:terrain)")]
    UnknownScene(String),
}

/// `Result<T, kdbeam::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

impl From<IsaError> for Error {
    /// [`IsaError::Unavailable`] is [`Error::IsaUnavailable`]; a `KDBEAM_ISA` that names no ISA
    /// is an [`Error::InvalidParameter`] named `KDBEAM_ISA`.
    fn from(e: IsaError) -> Self {
        match e {
            IsaError::Unavailable(isa) => Error::IsaUnavailable(isa),
            e => Error::InvalidParameter {
                name: "KDBEAM_ISA",
                message: e.to_string(),
            },
        }
    }
}
