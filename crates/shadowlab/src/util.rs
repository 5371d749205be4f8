//! Small wgpu helpers: buffers, readbacks, dispatch sizes.

use wgpu::util::DeviceExt;

#[cfg(not(target_arch = "wasm32"))]
use crate::gpu::GpuError;

pub fn uniform_buffer(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

/// A small buffer that shaders branch on (a light, the dragged objects' counts): read as a uniform
/// without compute (WebGL2), as a read-only storage buffer otherwise (`context::branch_entry`).
/// Mesa's lavapipe (22.3) compiles a shader again, and keeps the old copy, at each draw or
/// dispatch after a uniform buffer whose values its branches read is bound; a light's kind
/// decides branches, and every light binds its own. Measured with the lights' buffers alone on
/// `room` (four lights, 128 × 96): still frames 11.3 → 4.7 ms, and 2.9 MB of memory a frame → none.
pub fn branch_buffer(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let storage =
        if crate::gpu::runs_compute(device) { wgpu::BufferUsages::STORAGE } else { wgpu::BufferUsages::empty() };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::UNIFORM | storage | wgpu::BufferUsages::COPY_DST,
    })
}

pub fn storage_buffer(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
    })
}

/// Workgroups of `size` threads needed to cover `n` items.
pub fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

/// Reads a whole 2D texture (mip 0, layer 0) back as tightly packed bytes (blocking: native only,
/// since a browser runs map callbacks only when control returns to it).
#[cfg(not(target_arch = "wasm32"))]
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, GpuError> {
    let size = texture.size();
    let unpadded = size.width * bytes_per_pixel;
    let padded = unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded) * u64::from(size.height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(size.height),
            },
        },
        wgpu::Extent3d { width: size.width, height: size.height, depth_or_array_layers: 1 },
    );
    queue.submit([encoder.finish()]);
    let data = map_read(device, &buffer)?;
    let mut out = Vec::with_capacity((unpadded * size.height) as usize);
    for row in data.chunks(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    Ok(out)
}

/// Reads a buffer back (blocking: native only).
#[cfg(not(target_arch = "wasm32"))]
pub fn read_buffer(device: &wgpu::Device, queue: &wgpu::Queue, source: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: source.size(),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(source, 0, &buffer, 0, source.size());
    queue.submit([encoder.finish()]);
    map_read(device, &buffer)
}

/// Maps a `MAP_READ` buffer and copies its contents out (blocking: native only).
#[cfg(not(target_arch = "wasm32"))]
pub fn map_read(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    // Mapping fails only when the device is lost.
    match rx.recv() {
        Ok(Ok(())) => {}
        other => return Err(GpuError::Lost(format!("readback failed: {other:?}"))),
    }
    let data = buffer.get_mapped_range(..).map_err(|e| GpuError::Lost(format!("readback failed: {e:?}")))?.to_vec();
    buffer.unmap();
    Ok(data)
}

/// Reinterprets little-endian bytes as f32 values.
pub fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// A single-layer 2D texture of `width × height` (screen-sized targets and buffers).
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    (width, height): (u32, u32),
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}
