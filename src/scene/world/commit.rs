//! Committing a scene: trees for the meshes that changed, in parallel, and the top level over
//! every instance, into the state that queries read.

use std::sync::Arc;

use glam::{Affine3A, Vec3};
use kdbeam_kernels::Aabb;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::top_level::TopLevel;
use super::transform::world_box;
use super::{tree_params, GeometryId, InstanceId, Scene, SceneHit};
use crate::kdtree::KdTree;
use crate::scene::Mesh;
use crate::Result;

/// The scene as of the last commit: what every query reads.
#[derive(Debug, Default)]
pub(super) struct Committed {
    /// Meshes and their trees, by geometry id.
    pub blas: Vec<Blas>,
    /// The traced placements: instances by id, then meshes traced as they are by geometry id.
    pub entries: Vec<Entry>,
    /// How many of `entries` are instances.
    pub instance_entries: usize,
    /// World box of each entry (empty for an empty mesh).
    pub boxes: Vec<Aabb>,
    /// The BVH over `boxes`.
    pub top: TopLevel,
}

/// A committed mesh.
#[derive(Debug)]
pub(super) struct Blas {
    pub geometry: u32,
    pub mesh: Arc<Mesh>,
    pub tree: Arc<KdTree>,
}

/// One traced placement of a mesh.
#[derive(Clone, Copy, Debug)]
pub(super) struct Entry {
    /// Index into [`Committed::blas`].
    pub blas: u32,
    pub geometry: u32,
    /// [`InstanceId::NONE`]'s value for a mesh traced as it is.
    pub instance: u32,
    pub to_object: Affine3A,
    /// No transform: the mesh traced as it is, the ray not carried over.
    pub as_is: bool,
    pub mask: u32,
}

impl Scene {
    /// Applies every change since the last commit: builds the kd-trees of the meshes added or
    /// updated since (in parallel across meshes with the `parallel` feature; the others keep
    /// theirs) and rebuilds the top level over the instances' boxes. Nothing changed: returns at
    /// once.
    ///
    /// # Errors
    /// What [`KdTree::build`] returns for a mesh; the queries then still see the previous
    /// commit, and the next commit tries again.
    pub fn commit(&mut self) -> Result<()> {
        if !self.changed && self.committed.is_some() {
            return Ok(());
        }
        let todo: Vec<(u32, Arc<Mesh>)> = self
            .geometries
            .iter()
            .filter(|(_, g)| g.tree.is_none())
            .map(|(id, g)| (id, Arc::clone(&g.mesh)))
            .collect();
        let set = self.params;
        let build = |(id, mesh): &(u32, Arc<Mesh>)| {
            let params = tree_params(set, mesh);
            (*id, KdTree::build(mesh, &params).map(|tree| (tree, params)))
        };
        #[cfg(feature = "parallel")]
        let built: Vec<_> = todo.par_iter().map(build).collect();
        #[cfg(not(feature = "parallel"))]
        let built: Vec<_> = todo.iter().map(build).collect();
        let mut first_error = None;
        for (id, tree) in built {
            match tree {
                Ok((tree, params)) => {
                    if let Some(g) = self.geometries.get_mut(id) {
                        g.tree = Some((Arc::new(tree), params));
                    }
                }
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        if let Some(e) = first_error {
            return Err(e);
        }

        let mut c = self.committed.take().unwrap_or_default();
        c.blas.clear();
        c.blas.extend(self.geometries.iter().filter_map(|(id, g)| {
            Some(Blas {
                geometry: id,
                mesh: Arc::clone(&g.mesh),
                tree: Arc::clone(&g.tree.as_ref()?.0),
            })
        }));
        c.entries.clear();
        c.boxes.clear();
        let blas_index = |blas: &[Blas], geometry: u32| {
            blas.binary_search_by_key(&geometry, |b| b.geometry)
                .ok()
                .map(|i| i as u32)
        };
        for (id, i) in self.instances.iter() {
            let Some(b) = blas_index(&c.blas, i.geometry) else {
                continue;
            };
            c.boxes
                .push(world_box(&i.to_world, &c.blas[b as usize].tree.bounds()));
            c.entries.push(Entry {
                blas: b,
                geometry: i.geometry,
                instance: id,
                to_object: i.to_object,
                as_is: false,
                mask: i.mask,
            });
        }
        c.instance_entries = c.entries.len();
        for (b, blas) in c.blas.iter().enumerate() {
            if self.geometries.get(blas.geometry).is_some_and(|g| g.as_is) {
                c.boxes.push(blas.tree.bounds());
                c.entries.push(Entry {
                    blas: b as u32,
                    geometry: blas.geometry,
                    instance: InstanceId::NONE.0,
                    to_object: Affine3A::IDENTITY,
                    as_is: true,
                    mask: u32::MAX,
                });
            }
        }
        c.top.rebuild(&c.boxes);
        self.committed = Some(c);
        self.changed = false;
        Ok(())
    }

    /// The unit geometric normal of `hit` in world space: the triangle's `(v1 − v0) × (v2 − v0)`
    /// carried by the inverse transpose of its instance's transform, normalised (so it faces
    /// the same side of the surface after a mirroring transform). `None` for a miss, a
    /// degenerate triangle, or a hit whose mesh or instance the last commit does not hold.
    #[must_use]
    pub fn normal(&self, hit: &SceneHit) -> Option<Vec3> {
        let c = self.committed.as_ref()?;
        let blas = c
            .blas
            .binary_search_by_key(&hit.geometry.0, |b| b.geometry)
            .ok()
            .map(|i| &c.blas[i])?;
        if hit.triangle as usize >= blas.mesh.triangle_count() {
            return None;
        }
        let tri = blas.mesh.triangle(hit.triangle as usize);
        let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
        let n = if hit.instance == InstanceId::NONE {
            n
        } else {
            let e = c.entries[..c.instance_entries]
                .binary_search_by_key(&hit.instance.0, |e| e.instance)
                .ok()
                .map(|i| &c.entries[i])?;
            if GeometryId(e.geometry) != hit.geometry {
                return None;
            }
            e.to_object.matrix3.transpose().mul_vec3(n)
        };
        n.try_normalize()
    }
}
