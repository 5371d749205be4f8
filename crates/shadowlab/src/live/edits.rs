//! Typed scene edits: what an application (or a timeline) may change between two frames.
//!
//! An edit is checked completely before anything changes: an unknown id, a NaN, a negative size or a
//! singular transform is an [`EditError`] and the scene stays as it was. Applied edits bump the
//! version counters that cached items record ([`super::scene::LiveScene`]); which items each kind of
//! edit invalidates is the table of [`super::validity`].

use glam::{Affine3A, Vec3};
use shadowlab_core::{Instance, Light, LightId, Mobility};

/// A stable handle of an instance of the live engine: never reused, unaffected by other
/// instances' removal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InstanceId(pub u32);

/// One change of a light.
#[derive(Debug, Clone, PartialEq)]
pub enum LightChange {
    /// Linear RGB colour: never touches shadow data (visibility is colour-free, DESIGN.md §3).
    Color(Vec3),
    Intensity(f32),
    /// The emitter's centre (point, spot and rect lights).
    Position(Vec3),
    /// The emitting direction (spot, directional and rect lights); normalised on apply.
    Direction(Vec3),
    /// The emitter's size: the sphere radius of point and spot lights, the angular radius (radians)
    /// of a directional light, the side of a square rect light (see also [`LightChange::Size`]).
    Radius(f32),
    /// A rect light's width and height.
    Size(f32, f32),
    /// The distance beyond which a local light has no effect (`None`: unbounded).
    Range(Option<f32>),
    /// Anything else: the whole light replaced.
    Replace(Light),
}

impl LightChange {
    /// Whether the change leaves the emitter's shape and placement (what shadows depend on) as it
    /// was.
    pub fn is_colour_only(&self) -> bool {
        matches!(self, Self::Color(_) | Self::Intensity(_))
    }
}

/// A change to the scene of a live engine, applied between frames.
#[derive(Debug, Clone, PartialEq)]
pub enum Edit {
    /// Moves, turns or scales an instance (its whole object-to-world transform).
    Transform {
        instance: InstanceId,
        transform: Affine3A,
    },
    /// Adds an instance of one of the scene's meshes and materials.
    AddInstance(Box<Instance>),
    RemoveInstance(InstanceId),
    /// Static, dynamic, or temporary (being dragged: out of every cache until released).
    Mobility {
        instance: InstanceId,
        mobility: Mobility,
    },
    Light {
        light: LightId,
        change: LightChange,
    },
    AddLight(Box<Light>),
    RemoveLight(LightId),
}

/// The kind of an edit, for the validity table: what it is, and for instances the mobility of the
/// instance concerned (its class before and after for a mobility change).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EditKind {
    MoveInstance(Mobility),
    AddInstance(Mobility),
    RemoveInstance(Mobility),
    ChangeMobility {
        from: Mobility,
        to: Mobility,
    },
    /// A light's position, direction, size or range.
    LightEmitter,
    /// A light's colour or intensity.
    LightColour,
    AddLight,
    RemoveLight,
    /// The output (visibility layers) resized.
    Resize,
    /// The camera moved (not an edit of the scene, but it changes what camera-fitted views hold).
    Camera,
}

impl EditKind {
    /// Every kind, with each mobility, for the table and its tests.
    pub fn all() -> Vec<EditKind> {
        let m = [Mobility::Static, Mobility::Dynamic, Mobility::Temporary];
        let mut v: Vec<EditKind> = Vec::new();
        v.extend(m.map(EditKind::MoveInstance));
        v.extend(m.map(EditKind::AddInstance));
        v.extend(m.map(EditKind::RemoveInstance));
        for from in m {
            for to in m {
                if from != to {
                    v.push(EditKind::ChangeMobility { from, to });
                }
            }
        }
        v.extend([
            EditKind::LightEmitter,
            EditKind::LightColour,
            EditKind::AddLight,
            EditKind::RemoveLight,
            EditKind::Resize,
            EditKind::Camera,
        ]);
        v
    }

    pub fn describe(&self) -> String {
        match self {
            Self::MoveInstance(m) => format!("move/turn/scale a {} instance", m.name()),
            Self::AddInstance(m) => format!("add a {} instance", m.name()),
            Self::RemoveInstance(m) => format!("remove a {} instance", m.name()),
            Self::ChangeMobility { from, to } => format!("{} → {}", from.name(), to.name()),
            Self::LightEmitter => "move/turn a light, change its size or range".into(),
            Self::LightColour => "change a light's colour or intensity".into(),
            Self::AddLight => "add a light".into(),
            Self::RemoveLight => "remove a light".into(),
            Self::Resize => "resize the output".into(),
            Self::Camera => "move the camera".into(),
        }
    }
}

/// An edit that could not be applied; the scene is unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    #[error("no instance {0:?} (removed, or never added)")]
    UnknownInstance(InstanceId),
    #[error("no light {0:?} (removed, or never added)")]
    UnknownLight(LightId),
    #[error("instance '{name}': {message}")]
    BadInstance { name: String, message: String },
    #[error("light '{name}': {message}")]
    BadLight { name: String, message: String },
    #[error("output size {width}×{height}: {message}")]
    BadSize { width: u32, height: u32, message: String },
    #[error("the scene needs at least one instance: '{0}' is the last")]
    LastInstance(String),
}

/// Checks an instance transform: finite and invertible (what renderers and the reference need).
pub(crate) fn check_transform(t: &Affine3A) -> Result<(), String> {
    if !t.is_finite() {
        return Err("transform is not finite".into());
    }
    let det = t.matrix3.determinant();
    if det.is_nan() || det.abs() <= 1e-18 {
        return Err(format!("transform is singular (determinant {det})"));
    }
    Ok(())
}
