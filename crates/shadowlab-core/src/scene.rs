//! The scene model shared by every part of shadowlab: meshes placed by instances, materials, lights
//! and named views.

use glam::{Affine3A, DVec3, Vec3};

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
/// (Toromanoff §II: semi-static scenes); dynamic ones are drawn over the cached static part each
/// frame they reach; a temporary object is one being dragged (Toromanoff §3.3): kept out of every
/// cache and shadowed by a pass of its own until it is released.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum Mobility {
    #[default]
    Static,
    Dynamic,
    Temporary,
}

impl Mobility {
    pub const NAMES: &[&str] = &["static", "dynamic", "temporary"];

    pub fn name(self) -> &'static str {
        match self {
            Self::Static => "static",
            Self::Dynamic => "dynamic",
            Self::Temporary => "temporary",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "static" => Some(Self::Static),
            "dynamic" => Some(Self::Dynamic),
            "temporary" => Some(Self::Temporary),
            _ => None,
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

/// `p` moved by `-shift`, rounded once (in `f64`, then to `f32`).
fn local(p: Vec3, shift: DVec3) -> Vec3 {
    (p.as_dvec3() - shift).as_vec3()
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
    /// World position of the scene's local origin: every `f32` coordinate of the scene (instance
    /// translations, lights, views) is relative to it. Zero until [`Scene::recentre`] moves it.
    pub origin: DVec3,
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
            origin: DVec3::ZERO,
        }
    }

    /// Moves the local origin near the scene's centre, so that the `f32` coordinates every renderer
    /// and the ray tracer work in stay small however far from the world's origin the scene lies:
    /// the large-world practice of rendering relative to a local origin (DESIGN.md §3, "robust far
    /// from the origin"). At 1e5 m a float's step is 8 mm, which is a shadow map's acne and the
    /// truth's self-shadowing; relative to the centre it is a few µm again.
    ///
    /// The new origin is the bounds' centre rounded to a grid of the scene's own size (the power of
    /// two at or above its diagonal), so scenes already around the world's origin do not move at
    /// all, and a scene and its copy translated by a multiple of that grid get the same local
    /// coordinates bit for bit. Shifts are computed in `f64`. Returns the shift applied (world
    /// minus local) in this call.
    pub fn recentre(&mut self) -> DVec3 {
        let b = self.bounds();
        if b.is_empty() || !b.diagonal().is_finite() {
            return DVec3::ZERO;
        }
        let grid = f64::from(b.diagonal()).max(1e-3).log2().ceil().exp2();
        let centre = (b.min.as_dvec3() + b.max.as_dvec3()) * 0.5;
        let shift = (centre / grid).round() * grid;
        if shift == DVec3::ZERO {
            return shift;
        }
        for i in &mut self.instances {
            i.transform.translation = local(Vec3::from(i.transform.translation), shift).into();
        }
        for l in &mut self.lights {
            l.translate(|p| local(p, shift));
        }
        for v in self.views.iter_mut().chain(self.paths.iter_mut().flat_map(|p| p.keys.iter_mut())) {
            v.position = local(v.position, shift);
            v.target = local(v.target, shift);
        }
        self.origin += shift;
        shift
    }

    /// Moves every instance, light and view by `by` in its own `f32` coordinates, as a file placing
    /// the scene there would (each coordinate rounded to `f32`; compare [`Scene::recentre`], which
    /// moves the origin instead and keeps the coordinates small).
    pub fn translate(&mut self, by: Vec3) {
        for i in &mut self.instances {
            i.transform.translation += glam::Vec3A::from(by);
        }
        for l in &mut self.lights {
            l.translate(|p| p + by);
        }
        for v in self.views.iter_mut().chain(self.paths.iter_mut().flat_map(|p| p.keys.iter_mut())) {
            v.position += by;
            v.target += by;
        }
    }

    /// A world position (in `f64`, e.g. from an application's large-world coordinates) in this
    /// scene's local frame.
    pub fn to_local(&self, world: DVec3) -> Vec3 {
        (world - self.origin).as_vec3()
    }

    /// A local position in world coordinates.
    pub fn to_world(&self, local: Vec3) -> DVec3 {
        local.as_dvec3() + self.origin
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::LightKind;
    use crate::primitives;

    fn far_scene(offset: Vec3) -> Scene {
        let mut s = Scene::new("far");
        let m = s.add_mesh(primitives::cuboid(Vec3::splat(2.0)));
        let mat = s.add_material(Material::default());
        s.add_instance(Instance::new("box", m, mat, Affine3A::from_translation(offset + Vec3::new(0.5, 1.0, 0.0))));
        let light = LightKind::Point { position: offset + Vec3::new(0.0, 4.0, 0.0), radius: 0.0 };
        s.add_light(Light::new("bulb", light, Vec3::ONE, 1.0));
        s.views.push(View::new("v", offset + Vec3::new(3.0, 2.0, 3.0), offset, 0.1, 50.0));
        s
    }

    #[test]
    fn recentring_moves_far_scenes_by_whole_grid_steps_and_leaves_near_ones() {
        let mut near = far_scene(Vec3::ZERO);
        assert_eq!(near.recentre(), DVec3::ZERO, "a scene around the origin stays");
        let mut far = far_scene(Vec3::new(1.0e5, 0.0, -3.0e5));
        let shift = far.recentre();
        // The box's diagonal is 3.46: grid 4; the centre (1e5 + 0.5, 1, −3e5) rounds to (1e5, 0, −3e5).
        assert_eq!(shift, DVec3::new(1.0e5, 0.0, -3.0e5));
        assert_eq!(far.origin, shift);
        assert_eq!(far.instances[0].transform.translation, near.instances[0].transform.translation);
        assert_eq!(far.lights[0].position(), near.lights[0].position());
        assert_eq!((far.views[0].position, far.views[0].target), (near.views[0].position, near.views[0].target));
        assert_eq!(far.to_local(DVec3::new(1.0e5, 4.0, -3.0e5)), Vec3::new(0.0, 4.0, 0.0));
        assert_eq!(far.to_world(Vec3::ONE), DVec3::new(1.0e5 + 1.0, 1.0, -3.0e5 + 1.0));
        assert_eq!(far.recentre(), DVec3::ZERO, "recentring twice is recentring once");
    }
}
