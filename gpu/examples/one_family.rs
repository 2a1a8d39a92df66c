//! A renderer's use of one exported table on the GPU, as a renderer author outside
//! this project writes it: wgpu, the `ktx2` crate, and the runtime crate
//! `lobefit-tables` (for the CPU comparison only); no type of the `lobefit` crate. It
//! evaluates the export's baked `lf_cap_exponent_baked` (`lobefit_baked.wgsl`: the
//! library with this export's constants, so no uniform to fill or bind) at 4096 cap
//! half-angles on the device and compares with the runtime's f64 lookup.
//!
//!     cargo run -p lobefit -- export --format ktx2 --only cap-exponent --out /tmp/ex
//!     cargo run -p lobefit-gpu --example one_family -- /tmp/ex
//!
//! The lines between `glue:` and `end of glue` are what using the table costs beyond
//! the renderer's own device, texture, buffer and pipeline setup (CI counts them).

use std::borrow::Cow;

use lobefit_tables::CapExponent;
use wgpu::util::DeviceExt;

const N: u32 = 4096;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: one_family EXPORT_DIR")?);
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))?;
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default()))?;

    // glue: the texture's texels and size, the baked shader.
    let bytes = std::fs::read(dir.join("cap-exponent.ktx2"))?;
    let ktx = ktx2::Reader::new(&bytes[..])?;
    let (w, h) = (ktx.header().pixel_width, ktx.header().pixel_height.max(1));
    let texels = ktx.levels().next().ok_or("no level")?.data;
    // Manual filtering: a non-filtering sampler (the default; it is never sampled).
    let sampler = device.create_sampler(&Default::default());
    let source = std::fs::read_to_string(dir.join("lobefit_baked.wgsl"))? + KERNEL;
    // end of glue

    // The renderer's own texture setup (an R32Float 2D texture of the KTX2's size).
    let size = wgpu::Extent3d {
        width: w,
        height: h,
        depth_or_array_layers: 1,
    };
    let texture = device.create_texture_with_data(
        &queue,
        &wgpu::TextureDescriptor {
            label: None,
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        texels,
    );

    // Cap half-angles over the table's domain [0.001, π/2) (e_cap = 0 beyond).
    let alphas: Vec<f32> = (0..N).map(|i| 0.001 + 1.5 * (i as f32 + 0.5) / N as f32).collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&alphas),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 4 * N as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 4 * N as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(Cow::Owned(source)),
    });
    // f32 textures filter only with FLOAT32_FILTERABLE: bind unfilterable, with a
    // non-filtering sampler (manual filtering never samples through it).
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    };
    let buffer = |ty| wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[
            entry(
                1,
                wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
            ),
            entry(2, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering)),
            entry(3, buffer(wgpu::BufferBindingType::Storage { read_only: true })),
            entry(4, buffer(wgpu::BufferBindingType::Storage { read_only: false })),
        ],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let view = texture.create_view(&Default::default());
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(N / 64, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, 4 * N as u64);
    queue.submit([encoder.finish()]);
    readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let got: Vec<f32> = bytemuck::cast_slice(&readback.slice(..).get_mapped_range()?).to_vec();

    let cpu = CapExponent::embedded()?;
    let mut worst = 0.0f64;
    for (&a, &g) in alphas.iter().zip(&got) {
        let want = cpu.e_cap(f64::from(a))?;
        worst = worst.max((f64::from(g) - want).abs() / want.abs().max(1e-30));
    }
    println!(
        "cap-exponent on {}: {N} angles, largest relative difference from the CPU lookup {worst:.2e}",
        adapter.get_info().name
    );
    if worst > 1e-4 {
        return Err(format!("the GPU differs from the CPU by {worst:e} (limit 1e-4)").into());
    }
    Ok(())
}

/// The renderer's kernel: bindings, and a call of the baked function.
const KERNEL: &str = "
@group(0) @binding(1) var T: texture_2d<f32>;
@group(0) @binding(2) var S: sampler;
@group(0) @binding(3) var<storage, read> X: array<f32>;
@group(0) @binding(4) var<storage, read_write> Y: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    Y[gid.x] = lf_cap_exponent_baked(T, S, X[gid.x]);
}
";
