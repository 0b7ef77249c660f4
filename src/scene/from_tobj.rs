//! Meshes from `tobj` (the `tobj` feature), for programs that already load their OBJ files with
//! it: the positions and indices of a [`tobj::Mesh`] checked as kdbeam checks its own input.

use crate::{Error, Mesh, Result};

impl TryFrom<&tobj::Mesh> for Mesh {
    type Error = Error;

    /// The triangles of a `tobj` mesh, with triangle ids in face order.
    ///
    /// A mesh loaded with `triangulate` holds triangles; otherwise each face of
    /// `face_arities[i]` vertices becomes a fan of `arity − 2` triangles around its first
    /// vertex, as [`load_obj`](crate::scene::load_obj) triangulates. Only positions are read:
    /// normals, texture coordinates and materials are ignored.
    ///
    /// # Errors
    /// [`Error::MalformedMesh`] when `positions` is not a multiple of 3 long, the indices are
    /// not triangles (no face arities and a length not a multiple of 3), a face has fewer than 3
    /// vertices, or the arities do not add up to the number of indices;
    /// [`Error::IndexOutOfRange`] for an index past the last vertex; [`Error::NonFinite`] for a
    /// NaN or infinite coordinate.
    ///
    /// ```
    /// let mut quad = tobj::Mesh::default();
    /// quad.positions = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    /// quad.indices = vec![0, 1, 2, 3];
    /// quad.face_arities = vec![4];
    /// let mesh = kdbeam::Mesh::try_from(&quad)?;
    /// assert_eq!(mesh.triangle_count(), 2);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    fn try_from(mesh: &tobj::Mesh) -> Result<Mesh> {
        if !mesh.positions.len().is_multiple_of(3) {
            return Err(Error::MalformedMesh(format!(
                "{} position coordinates is not a multiple of 3",
                mesh.positions.len()
            )));
        }
        let positions: Vec<[f32; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        if mesh.face_arities.is_empty() {
            return Mesh::from_indexed(&positions, &mesh.indices);
        }
        let total: usize = mesh.face_arities.iter().map(|&a| a as usize).sum();
        if total != mesh.indices.len() {
            return Err(Error::MalformedMesh(format!(
                "the face arities add up to {total} indices, but there are {}",
                mesh.indices.len()
            )));
        }
        let mut triangles = Vec::with_capacity(3 * mesh.indices.len());
        let mut rest = &mesh.indices[..];
        for (face, &arity) in mesh.face_arities.iter().enumerate() {
            let (indices, tail) = rest.split_at(arity as usize);
            rest = tail;
            let [first, others @ ..] = indices else {
                return Err(malformed_face(face, arity));
            };
            if others.len() < 2 {
                return Err(malformed_face(face, arity));
            }
            for pair in others.windows(2) {
                triangles.extend([*first, pair[0], pair[1]]);
            }
        }
        Mesh::from_indexed(&positions, &triangles)
    }
}

fn malformed_face(face: usize, arity: u32) -> Error {
    Error::MalformedMesh(format!("face {face} has {arity} vertices, fewer than 3"))
}
