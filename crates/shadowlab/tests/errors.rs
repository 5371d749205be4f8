//! Device errors (an impossible texture, out of memory) become error values, not panics.

mod common;

#[test]
fn device_errors_are_reported_not_raised() {
    let gpu = common::gpu();
    assert_eq!(gpu.take_error(), None);
    let _bad = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("too large"),
        size: wgpu::Extent3d { width: 1 << 20, height: 1 << 20, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let e = gpu.take_error().expect("the error was recorded");
    assert!(e.to_lowercase().contains("dimension") || e.to_lowercase().contains("size"), "{e}");
    assert_eq!(gpu.take_error(), None, "taken once");
}

/// A lost device (a driver reset, a browser's GPU process ended; here `destroy`) is recorded and
/// stays recorded: callers check [`shadowlab::Gpu::lost`] before drawing (the web page says so
/// and refuses work instead of drawing nothing, or panicking on a call that fails outright there).
#[test]
fn a_lost_device_is_recorded() {
    let gpu = common::gpu();
    assert_eq!(gpu.lost(), None);
    gpu.device.destroy();
    gpu.wait();
    let why = gpu.lost().expect("the loss was recorded");
    assert!(why.contains("lost") && why.contains("Destroyed"), "{why}");
    assert_eq!(gpu.lost().as_deref(), Some(why.as_str()), "it stays");
}
