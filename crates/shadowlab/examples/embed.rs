//! Embedding shadowlab in an application that owns its wgpu device and queue and renders its own
//! depth and normal buffers (here with standard Z, depth 0 at the near plane, unlike shadowlab's own
//! reversed Z). shadowlab only adds the shadows: one visibility layer per light, for the
//! application's lighting to multiply its lights by.
//!
//! Run: `cargo run -p shadowlab --example embed` (writes `embed-visibility.png`).

use glam::Mat4;
use shadowlab::timing::GpuTimer;
use shadowlab::{CameraUniform, Gpu, Shadows, SurfaceInputs, TechniqueSpec};
use shadowlab_core::{LightId, Scene, View};

/// The application's G-buffer shader: world normals into an `Rgba16Float` target.
const APP_SHADER: &str = r#"
struct Camera { view_proj: mat4x4<f32> };
@group(0) @binding(0) var<uniform> camera: Camera;
struct In {
    @location(0) position: vec3<f32>, @location(1) normal: vec3<f32>,
    @location(2) m0: vec4<f32>, @location(3) m1: vec4<f32>, @location(4) m2: vec4<f32>, @location(5) m3: vec4<f32>,
    @location(6) n0: vec4<f32>, @location(7) n1: vec4<f32>, @location(8) n2: vec4<f32>,
};
struct Out { @builtin(position) clip: vec4<f32>, @location(0) normal: vec3<f32> };
@vertex fn vs(v: In) -> Out {
    var o: Out;
    o.clip = camera.view_proj * (mat4x4<f32>(v.m0, v.m1, v.m2, v.m3) * vec4<f32>(v.position, 1.0));
    o.normal = mat3x3<f32>(v.n0.xyz, v.n1.xyz, v.n2.xyz) * v.normal;
    return o;
}
@fragment fn fs(i: Out, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return vec4<f32>(select(-1.0, 1.0, front) * normalize(i.normal), 0.0);
}
"#;

/// Renders the application's depth and normals for `view`, then lets shadowlab shadow `light` with
/// `technique`; returns that light's visibility (row-major, top row first). `gpu` wraps the
/// application's own device and queue ([`Gpu::from_device`]).
pub fn embedded_visibility(
    gpu: &Gpu,
    scene: Scene,
    view: &View,
    light: LightId,
    technique: &str,
    (width, height): (u32, u32),
) -> Vec<f32> {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let mut shadows = Shadows::new(gpu, scene);
    let spec = TechniqueSpec::parse(technique, &[]).expect("a valid technique spec");
    shadows.set_technique(light, &spec, width, height).expect("the technique supports the light");

    // The application's own targets and camera (standard Z: cleared to 1, closer is smaller).
    let target = |format, label| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
    };
    let depth = target(wgpu::TextureFormat::Depth32Float, "app depth");
    let normal = target(wgpu::TextureFormat::Rgba16Float, "app normals");
    let view_matrix = view.view_matrix();
    let projection: Mat4 =
        glam::camera::rh::proj::directx::perspective(view.fov_y, width as f32 / height as f32, view.near, view.far);
    let camera_buffer =
        shadowlab::util::uniform_buffer(device, "app camera", bytemuck::bytes_of(&(projection * view_matrix)));

    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("app"),
        source: wgpu::ShaderSource::Wgsl(APP_SHADER.into()),
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("app g-buffer"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(shadowlab::gpu_scene::VERTEX_LAYOUT), Some(shadowlab::gpu_scene::INSTANCE_LAYOUT)],
        },
        primitive: wgpu::PrimitiveState { cull_mode: Some(wgpu::Face::Back), ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: wgpu::TextureFormat::Rgba16Float,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    let camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("app camera"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera_buffer.as_entire_binding() }],
    });

    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let normal_view = normal.create_view(&Default::default());
        let depth_view = depth.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("app g-buffer"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &normal_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, Some(&camera_group), &[]);
        shadows.gpu_scene().bind(&mut pass);
        shadows.gpu_scene().draw(&mut pass, shadows.gpu_scene().groups.iter());
    }

    // The surface shadowlab shades: the application's buffers and camera (reversed_z = false).
    let surface = SurfaceInputs::new(
        device,
        depth
            .create_view(&wgpu::TextureViewDescriptor { aspect: wgpu::TextureAspect::DepthOnly, ..Default::default() }),
        normal.create_view(&Default::default()),
        CameraUniform::new(view_matrix, projection, width, height, false),
        width,
        height,
    );
    let mut timer = GpuTimer::new(gpu);
    shadows.record(&mut encoder, &surface, &mut timer).expect("shadows recorded");
    queue.submit([encoder.finish()]);

    // The application would now bind `shadows.layer(light).view` in its lighting pass; here we
    // read the layer back.
    let layer = shadows.layer(light).expect("the shadowed light");
    shadowlab::util::f32s(&shadowlab::util::read_texture(device, queue, &layer.texture, 4).expect("readback"))
}

#[allow(dead_code)]
fn main() {
    // An application's own device and queue.
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).expect("an adapter");
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default())).expect("a device");
    let scene = shadowlab_core::load_scene("room").expect("built-in scene").scene;
    let view = scene.view("default").expect("a view").clone();
    let sun = scene.find_light("sun").expect("the sun");
    // shadowlab on the application's device.
    let gpu = Gpu::from_device(device, queue, &adapter.get_info());
    let v = embedded_visibility(&gpu, scene, &view, sun, "pcf", (256, 256));
    let grey: Vec<u8> = v.iter().flat_map(|&x| [(x.clamp(0.0, 1.0) * 255.0) as u8; 3]).collect();
    let png = std::path::Path::new("embed-visibility.png");
    let img = image::RgbImage::from_raw(256, 256, grey).expect("size");
    img.save(png).expect("write the png");
    println!("sun visibility written to {}", png.display());
}
