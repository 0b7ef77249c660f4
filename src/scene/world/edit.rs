//! Changing a scene: meshes and instances added, updated and removed. Every change is seen by
//! queries after the next commit.

use std::sync::Arc;

use glam::{Affine3A, Vec3};

use super::transform::checked_inverse;
use super::{Geometry, GeometryId, Instance, InstanceId, Scene};
use crate::kdtree::KdTree;
use crate::scene::Mesh;
use crate::{Error, Result};

impl Scene {
    /// Adds a mesh traced as it is, in world space (its hits have [`InstanceId::NONE`]); it
    /// may also be instanced. Returns its id: `0, 1, …` in the order meshes are added.
    ///
    /// # Errors
    /// [`Error::IdsExhausted`] after `u32::MAX` meshes.
    pub fn add_mesh(&mut self, mesh: Mesh) -> Result<GeometryId> {
        self.insert_geometry(mesh, true)
    }

    /// Adds a mesh that is traced only through its instances ([`Scene::add_instance`]).
    ///
    /// # Errors
    /// As [`Scene::add_mesh`].
    pub fn add_prototype(&mut self, mesh: Mesh) -> Result<GeometryId> {
        self.insert_geometry(mesh, false)
    }

    fn insert_geometry(&mut self, mesh: Mesh, as_is: bool) -> Result<GeometryId> {
        let id = self.geometries.insert(Geometry {
            mesh: Arc::new(mesh),
            tree: None,
            as_is,
            instances: 0,
        })?;
        self.changed = true;
        Ok(GeometryId(id))
    }

    /// The mesh of `geometry`, as last added or updated.
    ///
    /// # Errors
    /// [`Error::UnknownGeometry`] for an id that names no mesh of this scene.
    pub fn mesh(&self, geometry: GeometryId) -> Result<&Mesh> {
        Ok(&self.geometry(geometry)?.mesh)
    }

    /// The kd-tree the last commit built for `geometry`'s mesh as last added or updated
    /// (`None` until a commit has built it): its nodes, leaves, bounds and build statistics.
    ///
    /// # Errors
    /// [`Error::UnknownGeometry`] for an id that names no mesh of this scene.
    pub fn tree(&self, geometry: GeometryId) -> Result<Option<&KdTree>> {
        Ok(self
            .geometry(geometry)?
            .tree
            .as_ref()
            .map(|(tree, _)| &**tree))
    }

    /// Gives `geometry` new vertex positions, its faces unchanged (a deforming mesh); the next
    /// commit rebuilds its tree and the boxes of its instances.
    ///
    /// # Errors
    /// [`Error::UnknownGeometry`] for a stale or unknown id, [`Error::VertexCountChanged`]
    /// when `positions` has another length than the mesh's vertices, [`Error::NonFinite`]
    /// for a NaN or infinite coordinate. The scene is unchanged on error.
    pub fn update_positions(&mut self, geometry: GeometryId, positions: &[[f32; 3]]) -> Result<()> {
        let g = self
            .geometries
            .get_mut(geometry.0)
            .ok_or(Error::UnknownGeometry(geometry.0))?;
        if positions.len() != g.mesh.positions().len() {
            return Err(Error::VertexCountChanged {
                geometry: geometry.0,
                expected: g.mesh.positions().len(),
                given: positions.len(),
            });
        }
        let mesh = Mesh::from_faces(
            positions.iter().map(|&p| Vec3::from(p)).collect(),
            g.mesh.faces().to_vec(),
        )?;
        g.mesh = Arc::new(mesh);
        g.tree = None;
        self.changed = true;
        Ok(())
    }

    /// Removes `geometry`; its id is never issued again.
    ///
    /// # Errors
    /// [`Error::UnknownGeometry`] for a stale or unknown id, [`Error::GeometryInUse`] while
    /// instances of it remain.
    pub fn remove_geometry(&mut self, geometry: GeometryId) -> Result<()> {
        let g = self.geometry(geometry)?;
        if g.instances > 0 {
            return Err(Error::GeometryInUse {
                geometry: geometry.0,
                instances: g.instances,
            });
        }
        self.geometries.remove(geometry.0);
        self.changed = true;
        Ok(())
    }

    /// Adds an instance of `geometry` placed by `to_world`, seen by every ray mask. Returns its
    /// id: `0, 1, …` in the order instances are added.
    ///
    /// # Errors
    /// [`Error::UnknownGeometry`] for a stale or unknown id, [`Error::InvalidTransform`] for a
    /// transform with a NaN or infinite entry or one that cannot be inverted,
    /// [`Error::IdsExhausted`] after `u32::MAX` instances.
    pub fn add_instance(&mut self, geometry: GeometryId, to_world: Affine3A) -> Result<InstanceId> {
        self.add_instance_masked(geometry, to_world, u32::MAX)
    }

    /// [`Scene::add_instance`] with a mask: the instance is seen by rays whose mask shares a bit
    /// with it ([`super::Query::mask`]); mask 0 hides it.
    ///
    /// # Errors
    /// As [`Scene::add_instance`].
    pub fn add_instance_masked(
        &mut self,
        geometry: GeometryId,
        to_world: Affine3A,
        mask: u32,
    ) -> Result<InstanceId> {
        self.geometry(geometry)?;
        let to_object = checked_inverse(&to_world)?;
        let id = self.instances.insert(Instance {
            geometry: geometry.0,
            to_world,
            to_object,
            mask,
        })?;
        if let Some(g) = self.geometries.get_mut(geometry.0) {
            g.instances += 1;
        }
        self.changed = true;
        Ok(InstanceId(id))
    }

    /// Moves `instance` to `to_world`.
    ///
    /// # Errors
    /// [`Error::UnknownInstance`] for a stale or unknown id, [`Error::InvalidTransform`] as in
    /// [`Scene::add_instance`]. The instance is unchanged on error.
    pub fn set_transform(&mut self, instance: InstanceId, to_world: Affine3A) -> Result<()> {
        let to_object = checked_inverse(&to_world)?;
        let i = self.instance_mut(instance)?;
        i.to_world = to_world;
        i.to_object = to_object;
        self.changed = true;
        Ok(())
    }

    /// The transform of `instance`, as last set.
    ///
    /// # Errors
    /// [`Error::UnknownInstance`] for a stale or unknown id.
    pub fn transform(&self, instance: InstanceId) -> Result<Affine3A> {
        self.instances
            .get(instance.0)
            .map(|i| i.to_world)
            .ok_or(Error::UnknownInstance(instance.0))
    }

    /// The geometry `instance` places.
    ///
    /// # Errors
    /// [`Error::UnknownInstance`] for a stale or unknown id.
    pub fn instance_geometry(&self, instance: InstanceId) -> Result<GeometryId> {
        self.instances
            .get(instance.0)
            .map(|i| GeometryId(i.geometry))
            .ok_or(Error::UnknownInstance(instance.0))
    }

    /// Sets the mask of `instance` (see [`Scene::add_instance_masked`]).
    ///
    /// # Errors
    /// [`Error::UnknownInstance`] for a stale or unknown id.
    pub fn set_instance_mask(&mut self, instance: InstanceId, mask: u32) -> Result<()> {
        self.instance_mut(instance)?.mask = mask;
        self.changed = true;
        Ok(())
    }

    /// Removes `instance`; its id is never issued again.
    ///
    /// # Errors
    /// [`Error::UnknownInstance`] for a stale or unknown id.
    pub fn remove_instance(&mut self, instance: InstanceId) -> Result<()> {
        let i = self
            .instances
            .remove(instance.0)
            .ok_or(Error::UnknownInstance(instance.0))?;
        if let Some(g) = self.geometries.get_mut(i.geometry) {
            g.instances -= 1;
        }
        self.changed = true;
        Ok(())
    }

    pub(super) fn geometry(&self, geometry: GeometryId) -> Result<&Geometry> {
        self.geometries
            .get(geometry.0)
            .ok_or(Error::UnknownGeometry(geometry.0))
    }

    fn instance_mut(&mut self, instance: InstanceId) -> Result<&mut Instance> {
        self.instances
            .get_mut(instance.0)
            .ok_or(Error::UnknownInstance(instance.0))
    }
}
