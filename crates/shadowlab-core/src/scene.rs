//! The scene model shared by every part of shadowlab: meshes placed by instances, materials, lights
//! and named views.

use glam::{Affine3A, Vec3};

use crate::bounds::Aabb;
use crate::camera::{CameraPath, View};
use crate::error::{Location, Result, SceneError};
use crate::light::Light;
use crate::material::Material;
use crate::mesh::Mesh;

/// Index of a mesh in [`Scene::meshes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

/// Index of a material in [`Scene::materials`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// Index of a light in [`Scene::lights`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LightId(pub u32);

macro_rules! id_index {
    ($($t:ty),*) => {$(
        impl $t {
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }
    )*};
}
id_index!(MeshId, MaterialId, LightId);

/// Whether something may change between frames. Static things are what caches may keep
/// (Toromanoff §II: semi-static scenes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mobility {
    #[default]
    Static,
    Dynamic,
}

impl Mobility {
    pub fn name(self) -> &'static str {
        match self {
            Self::Static => "static",
            Self::Dynamic => "dynamic",
        }
    }
}

/// What an object is for, when the scene knows (Toromanoff §II, "known object roles").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Role {
    /// Floors, walls, ceilings: large surfaces that mostly receive shadows.
    Receiver,
    /// Furniture and props: objects that mostly cast shadows.
    Occluder,
}

impl Role {
    pub fn name(self) -> &'static str {
        match self {
            Self::Receiver => "receiver",
            Self::Occluder => "occluder",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "receiver" => Some(Self::Receiver),
            "occluder" => Some(Self::Occluder),
            _ => None,
        }
    }
}

/// A mesh placed in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Instance {
    pub name: String,
    pub mesh: MeshId,
    pub material: MaterialId,
    /// Object to world.
    pub transform: Affine3A,
    pub mobility: Mobility,
    pub casts_shadows: bool,
    pub receives_shadows: bool,
    pub role: Option<Role>,
}

impl Instance {
    pub fn new(name: impl Into<String>, mesh: MeshId, material: MaterialId, transform: Affine3A) -> Self {
        Self {
            name: name.into(),
            mesh,
            material,
            transform,
            mobility: Mobility::Static,
            casts_shadows: true,
            receives_shadows: true,
            role: None,
        }
    }

    pub fn dynamic(&mut self) -> &mut Self {
        self.mobility = Mobility::Dynamic;
        self
    }

    pub fn with_role(&mut self, role: Role) -> &mut Self {
        self.role = Some(role);
        self
    }

    pub fn no_shadow(&mut self) -> &mut Self {
        self.casts_shadows = false;
        self
    }
}

/// Counts for listings and reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SceneStats {
    pub meshes: usize,
    pub instances: usize,
    /// Triangles drawn: every instance counts its mesh's triangles.
    pub triangles: usize,
    /// Triangles stored: each mesh once.
    pub unique_triangles: usize,
    pub lights: usize,
    pub views: usize,
}

/// Meshes, materials, instances, lights and views.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    pub lights: Vec<Light>,
    pub views: Vec<View>,
    /// Scripted camera paths (for flicker measurements).
    pub paths: Vec<CameraPath>,
    /// Ambient light (linear RGB), added unshadowed: `albedo · ambient` in DESIGN.md §3.
    pub ambient: Vec3,
}

impl Scene {
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            meshes: Vec::new(),
            materials: Vec::new(),
            instances: Vec::new(),
            lights: Vec::new(),
            views: Vec::new(),
            paths: Vec::new(),
            ambient: Vec3::splat(0.03),
        }
    }

    pub fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.meshes.push(mesh);
        MeshId(self.meshes.len() as u32 - 1)
    }

    pub fn add_material(&mut self, material: Material) -> MaterialId {
        self.materials.push(material);
        MaterialId(self.materials.len() as u32 - 1)
    }

    pub fn add_instance(&mut self, instance: Instance) -> &mut Instance {
        self.instances.push(instance);
        self.instances.last_mut().expect("just pushed")
    }

    pub fn add_light(&mut self, light: Light) -> LightId {
        self.lights.push(light);
        LightId(self.lights.len() as u32 - 1)
    }

    pub fn mesh(&self, id: MeshId) -> &Mesh {
        &self.meshes[id.index()]
    }

    pub fn material(&self, id: MaterialId) -> &Material {
        &self.materials[id.index()]
    }

    /// World-space bounds of all instances.
    pub fn bounds(&self) -> Aabb {
        self.bounds_where(|_| true)
    }

    /// World-space bounds of the instances that cast shadows.
    pub fn caster_bounds(&self) -> Aabb {
        self.bounds_where(|i| i.casts_shadows)
    }

    /// World-space bounds of the shadow casters that are not receivers (floors and walls): the
    /// objects whose penumbrae soft-shadow estimates care about.
    pub fn occluder_bounds(&self) -> Aabb {
        self.bounds_where(|i| i.casts_shadows && i.role != Some(Role::Receiver))
    }

    fn bounds_where(&self, keep: impl Fn(&Instance) -> bool) -> Aabb {
        let mesh_bounds: Vec<Aabb> = self.meshes.iter().map(Mesh::bounds).collect();
        self.instances
            .iter()
            .filter(|i| keep(i))
            .filter_map(|i| mesh_bounds.get(i.mesh.index()).map(|b| b.transformed(&i.transform)))
            .fold(Aabb::EMPTY, |a, b| a.union(&b))
    }

    pub fn stats(&self) -> SceneStats {
        SceneStats {
            meshes: self.meshes.len(),
            instances: self.instances.len(),
            triangles: self
                .instances
                .iter()
                .filter_map(|i| self.meshes.get(i.mesh.index()))
                .map(Mesh::triangle_count)
                .sum(),
            unique_triangles: self.meshes.iter().map(Mesh::triangle_count).sum(),
            lights: self.lights.len(),
            views: self.views.len(),
        }
    }

    pub fn view(&self, name: &str) -> Option<&View> {
        self.views.iter().find(|v| v.name == name)
    }

    pub fn path(&self, name: &str) -> Option<&CameraPath> {
        self.paths.iter().find(|p| p.name == name)
    }

    /// Finds a light by name or by decimal index.
    pub fn find_light(&self, name_or_index: &str) -> Option<LightId> {
        if let Some(i) = self.lights.iter().position(|l| l.name == name_or_index) {
            return Some(LightId(i as u32));
        }
        name_or_index.parse::<usize>().ok().filter(|&i| i < self.lights.len()).map(|i| LightId(i as u32))
    }

    /// Multiplies every light's emitter size by `s` (`--emitter-scale`; 0 makes all lights hard).
    pub fn scale_emitters(&mut self, s: f32) {
        for l in &mut self.lights {
            l.scale_emitter(s);
        }
    }

    /// Checks every invariant renderers and the reference rely on; the error names the element.
    pub fn validate(&self) -> Result<()> {
        let at = |what: String, message: String| SceneError::invalid(Location::path(what), message);
        if self.instances.is_empty() {
            return Err(at("scene".into(), format!("scene '{}' has no objects", self.name)));
        }
        if !(self.ambient.is_finite() && self.ambient.min_element() >= 0.0) {
            return Err(at("scene.ambient".into(), format!("ambient {} must be finite and ≥ 0", self.ambient)));
        }
        for (i, m) in self.meshes.iter().enumerate() {
            m.check().map_err(|e| at(format!("mesh[{i}] '{}'", m.name), e))?;
        }
        for (i, m) in self.materials.iter().enumerate() {
            m.check().map_err(|e| at(format!("material[{i}] '{}'", m.name), e))?;
        }
        for (i, inst) in self.instances.iter().enumerate() {
            let here = || format!("object[{i}] '{}'", inst.name);
            if inst.mesh.index() >= self.meshes.len() {
                return Err(at(here(), format!("mesh index {} out of range", inst.mesh.0)));
            }
            if inst.material.index() >= self.materials.len() {
                return Err(at(here(), format!("material index {} out of range", inst.material.0)));
            }
            if !inst.transform.is_finite() {
                return Err(at(here(), "transform is not finite".into()));
            }
            let det = inst.transform.matrix3.determinant();
            if det.is_nan() || det.abs() <= 1e-18 {
                return Err(at(here(), format!("transform is singular (determinant {det})")));
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            l.check().map_err(|e| at(format!("light[{i}] '{}'", l.name), e))?;
        }
        for (i, v) in self.views.iter().enumerate() {
            v.check().map_err(|e| at(format!("view[{i}] '{}'", v.name), e))?;
        }
        for (i, p) in self.paths.iter().enumerate() {
            if p.keys.is_empty() {
                return Err(at(format!("path[{i}] '{}'", p.name), "a path needs at least one view".into()));
            }
            for v in &p.keys {
                v.check().map_err(|e| at(format!("path[{i}] '{}'", p.name), e))?;
            }
        }
        let b = self.bounds();
        if b.is_empty() || !b.diagonal().is_finite() {
            return Err(at("scene".into(), "scene bounds are empty or infinite".into()));
        }
        Ok(())
    }
}
