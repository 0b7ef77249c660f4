//! OBJ loading (placeholder).
use std::path::Path;

use crate::{Mesh, Result};

/// Placeholder.
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh> {
    Err(crate::Error::NoTriangles {
        path: path.as_ref().into(),
    })
}
