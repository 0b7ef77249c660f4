//! Scenes of many meshes and instances, for renderers whose worlds move: [`Scene`].
//!
//! A scene holds meshes ([`GeometryId`]) and instances of them under affine transforms
//! ([`InstanceId`]). [`Scene::commit`] builds a kd-tree per changed mesh (in parallel across
//! meshes with the `parallel` feature) and a BVH over the instances' world boxes (see
//! `top_level.rs` for why a BVH); queries trace the scene as of the last commit. A ray enters
//! an instance as the same ray carried to the mesh's space by the inverse transform, so `t` is
//! the world ray's parameter. A packet ([`Scene::intersect_packet`],
//! [`Scene::occluded_packet`]) walks the top level as a whole and enters an instance as one
//! packet carried to the mesh's space, so the beam works in the instance's kd-tree leaves.
//!
//! This room sits above [`crate::trace`]: it builds on [`crate::KdTree`] and the tracer's
//! single-ray and packet paths, and nothing below imports it.
//!
//! ```
//! use kdbeam::scene::world::{InstanceId, Query, Scene};
//! use kdbeam::{Mesh, Ray, Vec3};
//! use glam::Affine3A;
//!
//! let quad = Mesh::from_indexed(
//!     &[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
//!     &[0, 1, 2, 0, 2, 3],
//! )?;
//! let mut scene = Scene::new();
//! let quad = scene.add_prototype(quad)?;
//! let near = scene.add_instance(quad, Affine3A::from_translation(Vec3::new(0.0, 0.0, 5.0)))?;
//! let far = scene.add_instance(quad, Affine3A::from_translation(Vec3::new(0.0, 0.0, 9.0)))?;
//! scene.commit()?;
//!
//! let ray = Ray::new(Vec3::new(0.5, 0.25, 0.0), Vec3::Z);
//! let hit = scene.intersect(&ray);
//! assert_eq!((hit.t, hit.geometry, hit.instance), (5.0, quad, near));
//! assert_eq!(scene.normal(&hit), Some(Vec3::Z));
//!
//! // Reject the near quad's hits: the far one is the closest accepted hit.
//! let skip_near = |h: &kdbeam::scene::world::SceneHit| h.instance != near;
//! let hit = scene.intersect_with(&ray, &Query { filter: Some(&skip_near), ..Query::default() });
//! assert_eq!((hit.t, hit.instance), (9.0, far));
//!
//! scene.set_transform(near, Affine3A::from_translation(Vec3::new(0.0, 0.0, 20.0)))?;
//! assert_eq!(scene.intersect(&ray).instance, near); // not committed yet
//! scene.commit()?;
//! assert_eq!(scene.intersect(&ray).instance, far);
//! # let _: InstanceId = far;
//! # Ok::<(), kdbeam::Error>(())
//! ```

mod commit;
mod edit;
mod hit;
mod ids;
mod packet;
mod top_level;
mod trace;
mod transform;

use std::sync::Arc;

use glam::Affine3A;
use kdbeam_kernels::{Dispatch, Isa};

use crate::kdtree::{BuildParams, KdTree};
use crate::scene::Mesh;
use crate::trace::Intersector;

pub use hit::{HitFilter, Query, SceneHit};
pub use ids::{GeometryId, InstanceId};

use commit::Committed;
use ids::Slots;

/// Meshes and instances of them, traced through a kd-tree per mesh and a BVH over instances.
///
/// Changes (`add_*`, `update_positions`, `set_transform`, `remove_*`) take `&mut self` and are
/// seen by queries only after [`Scene::commit`]; queries take `&self`, so a committed scene
/// can be traced from many threads at once (`Scene` is `Sync`), and no change can overlap a
/// query. A scene never committed traces as empty: every ray misses, and the stream queries
/// return [`crate::Error::NotCommitted`].
///
/// Ids are never reused: after `remove_*`, the old id names nothing and every call given it
/// fails with [`crate::Error::UnknownGeometry`] or [`crate::Error::UnknownInstance`].
#[derive(Debug)]
pub struct Scene {
    geometries: Slots<Geometry>,
    instances: Slots<Instance>,
    /// The parameters of every mesh's tree; `None`: each mesh's own ([`BuildParams::for_mesh`]).
    params: Option<BuildParams>,
    intersector: Intersector,
    /// The ISA of single rays and packets inside instances, resolved once, when the scene is
    /// made (as [`crate::Tracer::new`] resolves its own), or set by [`Scene::set_isa`].
    dispatch: Dispatch,
    /// Something changed since the last commit.
    changed: bool,
    committed: Option<Committed>,
}

/// The parameters of `mesh`'s tree: those `set` for every mesh, or else its own.
fn tree_params(set: Option<BuildParams>, mesh: &Mesh) -> BuildParams {
    set.unwrap_or_else(|| BuildParams::for_mesh(mesh))
}

/// A mesh, its tree once built, and where it is traced.
#[derive(Debug)]
struct Geometry {
    mesh: Arc<Mesh>,
    /// The tree and the parameters it was built with; `None` until the next commit builds it
    /// (a new or updated mesh, or other parameters).
    tree: Option<(Arc<KdTree>, BuildParams)>,
    /// Traced in world space as it is, besides its instances.
    as_is: bool,
    /// How many instances use it.
    instances: usize,
}

/// A placement of a geometry.
#[derive(Clone, Copy, Debug)]
struct Instance {
    geometry: u32,
    to_world: Affine3A,
    to_object: Affine3A,
    mask: u32,
}

impl Default for Scene {
    fn default() -> Self {
        Scene::new()
    }
}

impl Scene {
    /// An empty scene with the default intersector, each mesh's tree sized by its own
    /// triangles ([`BuildParams::for_mesh`]).
    #[must_use]
    pub fn new() -> Self {
        Scene {
            geometries: Slots::new("geometry"),
            instances: Slots::new("instance"),
            params: None,
            intersector: Intersector::default(),
            dispatch: Dispatch::preferred(),
            changed: true,
            committed: None,
        }
    }

    /// The ray–triangle test of every query.
    #[must_use]
    pub fn intersector(&self) -> Intersector {
        self.intersector
    }

    /// Chooses the ray–triangle test (seen at once: it needs no rebuild).
    pub fn set_intersector(&mut self, intersector: Intersector) {
        self.intersector = intersector;
    }

    /// The ISA every query runs on: the widest this CPU runs, or the one `KDBEAM_ISA` names,
    /// unless [`Scene::set_isa`] chose another.
    #[must_use]
    pub fn isa(&self) -> Isa {
        self.dispatch.isa()
    }

    /// Runs every query on `isa` (seen at once: it needs no rebuild). Every ISA gives the same
    /// hits, bit for bit.
    ///
    /// ```
    /// use kdbeam::{Isa, Scene};
    /// let mut scene = Scene::new();
    /// scene.set_isa(Isa::Scalar)?;
    /// assert_eq!(scene.isa(), Isa::Scalar);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`crate::Error::IsaUnavailable`] when this CPU does not run it; the scene is unchanged.
    pub fn set_isa(&mut self, isa: Isa) -> crate::Result<()> {
        self.dispatch = Dispatch::new(isa)?;
        Ok(())
    }

    /// The kd-tree build parameters set for every mesh ([`Scene::set_build_params`]), or
    /// `None` (the default) when each mesh's tree is sized by its own triangles,
    /// [`BuildParams::for_mesh`].
    #[must_use]
    pub fn build_params(&self) -> Option<&BuildParams> {
        self.params.as_ref()
    }

    /// The parameters `geometry`'s tree is built with: those set for every mesh, or else its
    /// own ([`BuildParams::for_mesh`] of its mesh as last added or updated).
    ///
    /// ```
    /// use kdbeam::scene::world::Scene;
    /// use kdbeam::{BuildParams, Mesh};
    ///
    /// // A large triangle beside a small one: its own tree is bigger than the default.
    /// let uneven = Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [0.0, 0.0, 1.0], [10.0, 0.0, 1.0], [0.0, 10.0, 1.0],
    /// ])?;
    /// let mut scene = Scene::new();
    /// let id = scene.add_mesh(uneven.clone())?;
    /// assert_eq!(scene.geometry_build_params(id)?, BuildParams::for_mesh(&uneven));
    ///
    /// scene.set_build_params(BuildParams::default())?;
    /// assert_eq!(scene.geometry_build_params(id)?, BuildParams::default());
    /// scene.reset_build_params();
    /// assert_eq!(scene.build_params(), None);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`crate::Error::UnknownGeometry`] for an id that names no mesh of this scene.
    pub fn geometry_build_params(&self, geometry: GeometryId) -> crate::Result<BuildParams> {
        let g = self.geometry(geometry)?;
        // A tree still held was built with what the scene gives its mesh now (`retire_trees`),
        // so its parameters spare measuring the mesh again.
        Ok(match &g.tree {
            Some((_, built)) => *built,
            None => tree_params(self.params, &g.mesh),
        })
    }

    /// Sets the kd-tree build parameters of every mesh; the next commit rebuilds the trees
    /// built with others.
    ///
    /// # Errors
    /// As [`BuildParams::validate`]; the scene is unchanged then.
    pub fn set_build_params(&mut self, params: BuildParams) -> crate::Result<()> {
        params.validate()?;
        if self.params != Some(params) {
            self.params = Some(params);
            self.retire_trees();
        }
        Ok(())
    }

    /// Back to the default: each mesh's tree sized by its own triangles
    /// ([`BuildParams::for_mesh`]); the next commit rebuilds the trees built with others.
    pub fn reset_build_params(&mut self) {
        if self.params.take().is_some() {
            self.retire_trees();
        }
    }

    /// Has the next commit rebuild the trees built with other parameters than the scene now
    /// gives their meshes.
    fn retire_trees(&mut self) {
        let set = self.params;
        for (_, g) in self.geometries.iter_mut() {
            if g.tree
                .as_ref()
                .is_some_and(|(_, built)| *built != tree_params(set, &g.mesh))
            {
                g.tree = None;
                self.changed = true;
            }
        }
    }

    /// How many meshes the scene holds (as edited, committed or not).
    #[must_use]
    pub fn geometry_count(&self) -> usize {
        self.geometries.len()
    }

    /// How many instances the scene holds (as edited, committed or not).
    #[must_use]
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Has the scene been committed at least once?
    #[must_use]
    pub fn is_committed(&self) -> bool {
        self.committed.is_some()
    }

    /// Are there changes that the next [`Scene::commit`] will apply?
    #[must_use]
    pub fn has_changes(&self) -> bool {
        self.changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_is_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<Scene>();
    }
}
