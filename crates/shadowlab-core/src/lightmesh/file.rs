//! The light-mesh file (`shadowlab precompute --out FILE`): light meshes with the hashes of what they
//! were made from, so that a file for another scene, an older format or a damaged file is refused
//! with a clear error instead of drawing wrong shadows (the engine then recomputes).
//!
//! Layout, little-endian (Hasselgren stores light meshes "in the world file" and describes no
//! format; this one is ours):
//!
//! ```text
//! magic      8 bytes  "SLLMESH\0"
//! version    u32      FORMAT_VERSION
//! scene      u64      static_hash(scene): the static instances (meshes, transforms, flags)
//! count      u32      light meshes
//! per mesh:  light u32, light hash u64 (position, direction, kind, range),
//!            vertices u32, triangles u32, positions 3 × f32 each, corners 3 × u32 each, instance u32 each,
//!            soft u32 (0 or 1), then with soft a visibility f32 per vertex (fake soft shadows)
//! checksum   u64      FNV-1a of every byte before it
//! ```

use std::path::Path;

use glam::Vec3;

use super::{LightMesh, is_static};
use crate::{Light, Scene};

pub const MAGIC: &[u8; 8] = b"SLLMESH\0";
pub const FORMAT_VERSION: u32 = 2;

/// Why a light-mesh file was refused.
#[derive(Debug, thiserror::Error)]
pub enum LightMeshFileError {
    #[error("cannot read or write {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("not a light-mesh file (no SLLMESH header)")]
    NotALightMeshFile,
    #[error("light-mesh file format {found}, this build reads {expected}: run `shadowlab precompute` again")]
    Version { found: u32, expected: u32 },
    #[error("the light-mesh file is damaged: {0}")]
    Corrupt(String),
    #[error(
        "the light-mesh file was made for another scene (or the static part changed): run `shadowlab precompute` again"
    )]
    OtherScene,
}

/// 64-bit FNV-1a.
#[derive(Debug, Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub fn f32s(&mut self, values: &[f32]) {
        for v in values {
            self.bytes(&v.to_le_bytes());
        }
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The hash of the scene's static part: what every light mesh depends on.
pub fn static_hash(scene: &Scene) -> u64 {
    let mut h = Fnv::default();
    for inst in scene.instances.iter().filter(|i| is_static(i)) {
        let mesh = scene.mesh(inst.mesh);
        h.bytes(&(mesh.positions.len() as u64).to_le_bytes());
        for p in &mesh.positions {
            h.f32s(&p.to_array());
        }
        for t in &mesh.triangles {
            for i in t {
                h.bytes(&i.to_le_bytes());
            }
        }
        h.f32s(&inst.transform.to_cols_array());
        h.bytes(&[
            u8::from(inst.casts_shadows),
            u8::from(inst.receives_shadows),
            u8::from(scene.material(inst.material).double_sided),
        ]);
    }
    h.finish()
}

/// The hash of what a light mesh takes from its light: kind, position or direction, range.
pub fn light_hash(light: &Light) -> u64 {
    let mut h = Fnv::default();
    h.bytes(light.type_name().as_bytes());
    h.f32s(&light.position().unwrap_or(Vec3::ZERO).to_array());
    h.f32s(&light.direction().unwrap_or(Vec3::ZERO).to_array());
    h.f32s(&[light.range.unwrap_or(f32::INFINITY)]);
    h.finish()
}

/// The file's bytes for `meshes` of `scene`.
pub fn encode(scene: &Scene, meshes: &[LightMesh]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&static_hash(scene).to_le_bytes());
    out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
    for m in meshes {
        let light_hash = scene.lights.get(m.light as usize).map_or(0, light_hash);
        out.extend_from_slice(&m.light.to_le_bytes());
        out.extend_from_slice(&light_hash.to_le_bytes());
        out.extend_from_slice(&(m.positions.len() as u32).to_le_bytes());
        out.extend_from_slice(&(m.triangles.len() as u32).to_le_bytes());
        for p in &m.positions {
            for c in p.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        for t in &m.triangles {
            for i in t {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
        for i in &m.instances {
            out.extend_from_slice(&i.to_le_bytes());
        }
        let soft = !m.visibility.is_empty();
        out.extend_from_slice(&u32::from(soft).to_le_bytes());
        for v in &m.visibility {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut h = Fnv::default();
    h.bytes(&out);
    out.extend_from_slice(&h.finish().to_le_bytes());
    out
}

/// What a file held for a scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Decoded {
    /// Light meshes still valid for the scene.
    pub meshes: Vec<LightMesh>,
    /// Lights whose mesh in the file was made for another position, direction or range (to rebuild).
    pub stale: Vec<usize>,
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], LightMeshFileError> {
        let end =
            self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
                LightMeshFileError::Corrupt(format!("ends at byte {} inside a record", self.bytes.len()))
            })?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self) -> Result<u32, LightMeshFileError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap_or_default()))
    }

    fn u64(&mut self) -> Result<u64, LightMeshFileError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap_or_default()))
    }

    fn f32(&mut self) -> Result<f32, LightMeshFileError> {
        Ok(f32::from_le_bytes(self.take(4)?.try_into().unwrap_or_default()))
    }
}

/// Reads a file's bytes for `scene`: refuses other formats, damage and other scenes.
pub fn decode(bytes: &[u8], scene: &Scene) -> Result<Decoded, LightMeshFileError> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(LightMeshFileError::NotALightMeshFile);
    }
    let mut r = Reader { bytes, at: MAGIC.len() };
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(LightMeshFileError::Version { found: version, expected: FORMAT_VERSION });
    }
    if bytes.len() < MAGIC.len() + 4 + 8 {
        return Err(LightMeshFileError::Corrupt("too short".into()));
    }
    let (body, tail) = bytes.split_at(bytes.len() - 8);
    let mut h = Fnv::default();
    h.bytes(body);
    if u64::from_le_bytes(tail.try_into().unwrap_or_default()) != h.finish() {
        return Err(LightMeshFileError::Corrupt("checksum mismatch".into()));
    }
    let mut r = Reader { bytes: body, at: r.at };
    if r.u64()? != static_hash(scene) {
        return Err(LightMeshFileError::OtherScene);
    }
    let count = r.u32()?;
    let mut out = Decoded::default();
    for _ in 0..count {
        let light = r.u32()?;
        let hash = r.u64()?;
        let (nv, nt) = (r.u32()? as usize, r.u32()? as usize);
        // Sizes are checked against the bytes left before anything is allocated.
        if nv.saturating_mul(12).saturating_add(nt.saturating_mul(16)) > body.len() - r.at {
            return Err(LightMeshFileError::Corrupt(format!(
                "light {light}: {nv} vertices, {nt} triangles do not fit"
            )));
        }
        let mut m = LightMesh { light, ..LightMesh::default() };
        for _ in 0..nv {
            let p = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
            if !p.is_finite() {
                return Err(LightMeshFileError::Corrupt(format!("light {light}: a vertex is not finite")));
            }
            m.positions.push(p);
        }
        for _ in 0..nt {
            let t = [r.u32()?, r.u32()?, r.u32()?];
            if t.iter().any(|&i| i as usize >= nv) {
                return Err(LightMeshFileError::Corrupt(format!("light {light}: a corner index is out of range")));
            }
            m.triangles.push(t);
        }
        for _ in 0..nt {
            let i = r.u32()?;
            if i as usize >= scene.instances.len() {
                return Err(LightMeshFileError::Corrupt(format!("light {light}: instance {i} is not in the scene")));
            }
            m.instances.push(i);
        }
        match r.u32()? {
            0 => {}
            1 => {
                if nv.saturating_mul(4) > body.len() - r.at {
                    return Err(LightMeshFileError::Corrupt(format!("light {light}: visibility does not fit")));
                }
                for _ in 0..nv {
                    let v = r.f32()?;
                    if !(0.0..=1.0).contains(&v) {
                        return Err(LightMeshFileError::Corrupt(format!("light {light}: a visibility outside [0, 1]")));
                    }
                    m.visibility.push(v);
                }
            }
            other => return Err(LightMeshFileError::Corrupt(format!("light {light}: soft flag {other}"))),
        }
        match scene.lights.get(light as usize) {
            Some(l) if light_hash(l) == hash => out.meshes.push(m),
            Some(_) => out.stale.push(light as usize),
            None => return Err(LightMeshFileError::Corrupt(format!("light {light} is not in the scene"))),
        }
    }
    if r.at != body.len() {
        return Err(LightMeshFileError::Corrupt(format!("{} bytes after the last light mesh", body.len() - r.at)));
    }
    Ok(out)
}

/// Writes the file; returns its size in bytes.
pub fn write(path: &Path, scene: &Scene, meshes: &[LightMesh]) -> Result<u64, LightMeshFileError> {
    let bytes = encode(scene, meshes);
    std::fs::write(path, &bytes)
        .map_err(|source| LightMeshFileError::Io { path: path.display().to_string(), source })?;
    Ok(bytes.len() as u64)
}

/// Reads the file for `scene`.
pub fn read(path: &Path, scene: &Scene) -> Result<Decoded, LightMeshFileError> {
    let bytes = crate::load::read_regular(path)
        .map_err(|source| LightMeshFileError::Io { path: path.display().to_string(), source })?;
    decode(&bytes, scene)
}
