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

/// Buffers sized by the output (the sample sums of `sampled`, `cssm` and several-sample `volumes`,
/// 8 bytes a pixel; `ssm`'s pull-push levels) that would outgrow a storage binding (128 MiB on CPU
/// adapters and in browsers: past about 16.7 million pixels) are a clear error from the technique,
/// naming the output and the limit, not a failed binding. The output is the smallest square past
/// the limit for 8 bytes a pixel, where it is a size a renderer can draw.
#[test]
fn an_output_past_the_binding_limit_is_a_clear_error() {
    use shadowlab::{Renderer, TechniqueSpec};
    use shadowlab_core::LightId;
    let gpu = common::gpu();
    let limits = gpu.device.limits();
    let limit = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    let side = ((limit / 8) as f64).sqrt().floor() as u32 + 1;
    if side > limits.max_texture_dimension_2d.min(8192) {
        println!("binding limit {limit}: an output past it ({side}²) is beyond what this test draws");
        return;
    }
    let scene = shadowlab_core::load_scene("penumbra").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut renderer = Renderer::new(&gpu, scene, &view, side, side);
    for spec in ["sampled:samples=4", "cssm", "volumes:samples=4", "ssm"] {
        renderer.set_technique(LightId(0), &TechniqueSpec::parse(spec, &[]).unwrap()).unwrap();
        let message = match renderer.render() {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{spec}: rendered {side}² past a binding limit of {limit} bytes"),
        };
        let id = spec.split(':').next().unwrap();
        assert!(
            message.contains(&format!("technique '{id}'")) && message.contains(&format!("{side} × {side}")),
            "{spec}: unclear: {message}"
        );
    }
}

/// Maps past the device's memory allocate without a validation error, and the device's own
/// message ("Out of Memory") names nothing: the frame's error adds what the shadows ask for and
/// which light's technique asks for most. `cssm:size0=8192` on `room` asks for 25 GiB (its
/// whole-room views keep the largest cascade size for every sample), past lavapipe's heap on
/// these 24 GB machines; a GPU that holds it has nothing to report.
#[test]
fn running_out_of_memory_names_the_largest_holder() {
    use shadowlab::{Renderer, TechniqueSpec};
    let gpu = common::gpu();
    let scene = shadowlab_core::load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let mut renderer = Renderer::new(&gpu, scene, &view, 32, 24);
    let spec = TechniqueSpec::parse("cssm:size0=8192", &[]).unwrap();
    for light in 0..renderer.scene().lights.len() {
        renderer.set_technique(shadowlab_core::LightId(light as u32), &spec).unwrap();
    }
    let message = match renderer.render() {
        Err(e) => e.to_string(),
        Ok(_) => {
            println!("{}: held 25 GiB of maps, no error to check", gpu.adapter.name);
            return;
        }
    };
    assert!(message.contains(shadowlab::OUT_OF_MEMORY), "another error: {message}");
    assert!(
        message.contains("GiB of GPU memory") && message.contains("`cssm:size0=8192` on light"),
        "the holder unnamed: {message}"
    );
}
