fn main() {
    for choice in [shadowlab::gpu::BackendChoice::Vulkan, shadowlab::gpu::BackendChoice::Gl] {
        match shadowlab::gpu::Gpu::new(choice) {
            Ok(g) => println!(
                "{:?}: {} timestamps={} features={:?}\n limits: tex2d {} layers {} storage_tex {}",
                choice,
                g.adapter,
                g.timestamps,
                g.device.features(),
                g.device.limits().max_texture_dimension_2d,
                g.device.limits().max_texture_array_layers,
                g.device.limits().max_storage_textures_per_shader_stage
            ),
            Err(e) => println!("{choice:?}: {e}"),
        }
    }
}
