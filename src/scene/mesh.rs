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

    /// How unevenly the surface is shared among the triangles: the area-weighted median
    /// triangle area over the mean area of the triangles that have one.
    ///
    /// Half of the surface lies in triangles at least that much larger than the mean. 1 for
    /// triangles of equal area; near 1 for a scanned model's even tessellation; in the
    /// hundreds where a few large triangles hold most of the surface (the walls and floors of
    /// an interior beside its detailed ornaments). The median is read from a histogram of four
    /// bins per octave of area, as the mean area of its bin, so the ratio is within 25% of the
    /// exact one, and exact where the bin's triangles have one area. Degenerate triangles, and
    /// areas that overflow `f32`, are left out; a mesh with no area left (empty, or every
    /// triangle degenerate) gives 1.
    ///
    /// ```
    /// use kdbeam::Mesh;
    ///
    /// // Two unit right triangles: the same area.
    /// let even = Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0],
    /// ])?;
    /// assert_eq!(even.area_spread(), 1.0);
    /// // Ten times larger on each side: the large one holds 100/101 of the surface.
    /// let uneven = Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [0.0, 0.0, 1.0], [10.0, 0.0, 1.0], [0.0, 10.0, 1.0],
    /// ])?;
    /// let exact = 50.0 / (101.0 / 2.0 / 2.0);
    /// assert!((uneven.area_spread() / exact - 1.0).abs() < 1e-6);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn area_spread(&self) -> f32 {
        // An area's bin: its exponent and the top two bits of its mantissa (`f32` bits >> 21),
        // with the sum and the number of the areas in it.
        const SHIFT: u32 = 21;
        let mut bins = vec![(0f64, 0u64); 1 << (32 - SHIFT)];
        let (mut total, mut count) = (0f64, 0u64);
        for t in self.triangles() {
            let area = 0.5 * (t.v1 - t.v0).cross(t.v2 - t.v0).length();
            if area > 0.0 && area.is_finite() {
                let bin = &mut bins[(area.to_bits() >> SHIFT) as usize];
                *bin = (bin.0 + f64::from(area), bin.1 + 1);
                total += f64::from(area);
                count += 1;
            }
        }
        if count == 0 {
            return 1.0;
        }
        let mut below = 0.0;
        let median = bins.iter().find(|&&(sum, _)| {
            below += sum;
            below >= total / 2.0
        });
        median.map_or(1.0, |&(sum, n)| {
            (sum / n as f64 * count as f64 / total) as f32
        })
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

#[cfg(test)]
mod tests {
    use super::Mesh;

    /// `n` right triangles with legs of `size` at height `y`, side by side.
    fn triangles(size: f32, n: usize, y: f32) -> Vec<[f32; 3]> {
        (0..n)
            .flat_map(|i| {
                let x = 2.0 * size * i as f32;
                [[x, y, 0.0], [x + size, y, 0.0], [x, y + size, 0.0]]
            })
            .collect()
    }

    /// Degenerate triangles are left out, a mesh without area gives 1, and the spread grows
    /// with the share of the surface in large triangles.
    #[test]
    fn area_spread_weighs_the_surface_by_triangle() {
        assert_eq!(Mesh::from_soup(&[]).unwrap().area_spread(), 1.0);
        let flat = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(Mesh::from_soup(&flat).unwrap().area_spread(), 1.0);
        let mut even = triangles(1.0, 100, 0.0);
        even.extend(flat);
        assert_eq!(Mesh::from_soup(&even).unwrap().area_spread(), 1.0);
        // 100 small triangles and k large ones of 100 times their area: the large ones hold
        // the median from k = 2 on (at k = 1 each size holds half), and the mean grows with k.
        let mut last = f32::INFINITY;
        for k in [2, 5, 20] {
            let mut mesh = triangles(1.0, 100, 0.0);
            mesh.extend(triangles(10.0, k, 50.0));
            let spread = Mesh::from_soup(&mesh).unwrap().area_spread();
            let exact = 50.0 / ((100.0 * 0.5 + k as f32 * 50.0) / (100 + k) as f32);
            assert!((spread / exact - 1.0).abs() < 1e-5, "{k}: {spread} {exact}");
            assert!(spread > 1.0 && spread < last, "{k}: {spread}");
            last = spread;
        }
    }
}
