//! Validated triangle meshes.

use glam::Vec3;
use kdbeam_kernels::{Aabb, Triangle};

use crate::{Error, Result};

/// A triangle mesh whose every coordinate is finite and every index in range.
///
/// Degenerate (zero-area) triangles are kept, so that triangle ids stay those of the input, but
/// no intersector ever reports a hit on one. An empty mesh is valid: every ray misses it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// A mesh from vertex positions and a flat list of `u32` indices, three per triangle.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a NaN or infinite coordinate, [`Error::MalformedMesh`] when
    /// `indices.len()` is not a multiple of 3 or there are more than `u32::MAX` vertices,
    /// [`Error::IndexOutOfRange`] for an index `>= positions.len()`.
    ///
    /// ```
    /// let mesh = kdbeam::Mesh::from_indexed(
    ///     &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    ///     &[0, 1, 2],
    /// )?;
    /// assert_eq!(mesh.triangle_count(), 1);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    pub fn from_indexed(positions: &[[f32; 3]], indices: &[u32]) -> Result<Mesh> {
        if !indices.len().is_multiple_of(3) {
            return Err(Error::MalformedMesh(format!(
                "{} indices is not a multiple of 3",
                indices.len()
            )));
        }
        let faces: Vec<[u32; 3]> = indices
            .chunks_exact(3)
            .map(|f| [f[0], f[1], f[2]])
            .collect();
        Mesh::from_faces(positions.iter().map(|&p| Vec3::from(p)).collect(), faces)
    }

    /// A mesh from a triangle soup: every three positions make one triangle.
    ///
    /// # Errors
    /// As [`Mesh::from_indexed`].
    pub fn from_soup(positions: &[[f32; 3]]) -> Result<Mesh> {
        if !positions.len().is_multiple_of(3) {
            return Err(Error::MalformedMesh(format!(
                "{} soup positions is not a multiple of 3",
                positions.len()
            )));
        }
        let n = u32::try_from(positions.len()).map_err(|_| too_many(positions.len()))?;
        let faces = (0..n / 3).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        Mesh::from_faces(positions.iter().map(|&p| Vec3::from(p)).collect(), faces)
    }

    /// A mesh from owned positions and faces, validated.
    ///
    /// # Errors
    /// As [`Mesh::from_indexed`].
    pub fn from_faces(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Mesh> {
        if u32::try_from(positions.len()).is_err() {
            return Err(too_many(positions.len()));
        }
        if let Some((vertex, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(Error::NonFinite {
                vertex,
                position: p.to_array(),
            });
        }
        for (face, f) in faces.iter().enumerate() {
            if let Some(&index) = f.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(Error::IndexOutOfRange {
                    face,
                    index: u64::from(index),
                    vertex_count: positions.len(),
                });
            }
        }
        Ok(Mesh {
            positions,
            indices: faces,
        })
    }

    /// Appends `other`, its triangle ids following this mesh's.
    pub fn append(&mut self, other: &Mesh) -> Result<()> {
        let base = u32::try_from(self.positions.len())
            .ok()
            .filter(|b| b.checked_add(other.positions.len() as u32).is_some())
            .ok_or_else(|| too_many(self.positions.len() + other.positions.len()))?;
        self.positions.extend_from_slice(&other.positions);
        self.indices
            .extend(other.indices.iter().map(|f| f.map(|i| i + base)));
        Ok(())
    }

    /// Number of triangles (degenerate ones included).
    #[inline]
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// True when there are no triangles.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Triangle `i`. Panics if `i >= triangle_count()`.
    #[inline]
    #[must_use]
    pub fn triangle(&self, i: usize) -> Triangle {
        let [a, b, c] = self.indices[i];
        Triangle::new(
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        )
    }

    /// Every triangle, in id order.
    #[must_use]
    pub fn triangles(&self) -> impl ExactSizeIterator<Item = Triangle> + '_ {
        (0..self.indices.len()).map(|i| self.triangle(i))
    }

    /// Vertex positions.
    #[inline]
    #[must_use]
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Faces, as three vertex indices each.
    #[inline]
    #[must_use]
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.indices
    }

    /// The box around every vertex that some triangle uses (empty for an empty mesh).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(
            self.indices
                .iter()
                .flatten()
                .map(|&i| self.positions[i as usize]),
        )
    }
}

fn too_many(n: usize) -> Error {
    Error::MalformedMesh(format!("{n} vertices do not fit u32 indices"))
}
