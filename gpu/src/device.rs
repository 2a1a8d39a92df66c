//! A headless wgpu device on the Vulkan backend (lavapipe without a GPU), the exported
//! textures uploaded as GPU textures, and compute kernels run over input arrays.

use std::borrow::Cow;

use lobefit::export::{Storage, Texture};
use wgpu::util::DeviceExt;

/// The device and what it supports.
pub struct Gpu {
    /// Adapter name, driver, backend (for the report).
    pub info: wgpu::AdapterInfo,
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Whether 32-bit float textures may be linearly filtered (hardware filtering of
    /// f32 exports).
    pub float32_filterable: bool,
}

/// A texture on the device with its view (1D tables: 2D of height 1; layered: 2D array).
pub struct GpuTexture {
    _texture: wgpu::Texture,
    view: wgpu::TextureView,
    view_dimension: wgpu::TextureViewDimension,
    filterable: bool,
    /// The WGSL type a kernel declares for it ([`wgsl_texture_type`]).
    pub wgsl_type: &'static str,
}

/// The WGSL type a kernel declares for a texture of `t` (see [`Gpu::upload`]).
pub fn wgsl_texture_type(t: &Texture) -> &'static str {
    match (t.dimension, t.layers) {
        (3, _) => "texture_3d<f32>",
        (_, 1) => "texture_2d<f32>",
        _ => "texture_2d_array<f32>",
    }
}

impl Gpu {
    /// A device on the first Vulkan adapter (high performance preferred). Errors say
    /// clearly when there is none.
    pub fn new() -> Result<Gpu, String> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| {
            format!(
                "no Vulkan adapter: {e}. Install a Vulkan driver (without a GPU: Mesa's lavapipe, \
                 Debian/Ubuntu packages mesa-vulkan-drivers and libvulkan1)"
            )
        })?;
        let info = adapter.get_info();
        let float32_filterable = adapter.features().contains(wgpu::Features::FLOAT32_FILTERABLE);
        let required_features = if float32_filterable {
            wgpu::Features::FLOAT32_FILTERABLE
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lobefit-gpu"),
            required_features,
            required_limits: wgpu::Limits::default(),
            ..Default::default()
        }))
        .map_err(|e| format!("Vulkan adapter {:?}: cannot create a device: {e}", info.name))?;
        Ok(Gpu {
            info,
            device,
            queue,
            float32_filterable,
        })
    }

    /// Uploads an exported texture in its storage precision (R/RG/RGBA 32F or 16F).
    pub fn upload(&self, t: &Texture, storage: Storage) -> Result<GpuTexture, String> {
        let format = match (storage, t.channels) {
            (Storage::F32, 1) => wgpu::TextureFormat::R32Float,
            (Storage::F32, 2) => wgpu::TextureFormat::Rg32Float,
            (Storage::F32, _) => wgpu::TextureFormat::Rgba32Float,
            (Storage::F16, 1) => wgpu::TextureFormat::R16Float,
            (Storage::F16, 2) => wgpu::TextureFormat::Rg16Float,
            (Storage::F16, _) => wgpu::TextureFormat::Rgba16Float,
        };
        let bytes: Vec<u8> = match storage {
            Storage::F32 => bytemuck::cast_slice(&t.data).to_vec(),
            Storage::F16 => t
                .data
                .iter()
                .flat_map(|&v| half::f16::from_f32(v).to_bits().to_le_bytes())
                .collect(),
        };
        // The device's limits before the upload (wgpu would panic past them).
        let limits = self.device.limits();
        let (max_extent, what) = if t.dimension == 3 {
            (limits.max_texture_dimension_3d, "3D")
        } else {
            (limits.max_texture_dimension_2d, "2D")
        };
        let largest = t.width.max(t.height).max(if t.dimension == 3 { t.depth } else { 1 });
        if largest > max_extent || t.layers > limits.max_texture_array_layers {
            return Err(format!(
                "texture {}: {}×{}×{} with {} layers exceeds this device's limits ({what} extent {max_extent}, \
                 {} array layers); export it at a smaller --scale",
                t.name, t.width, t.height, t.depth, t.layers, limits.max_texture_array_layers
            ));
        }
        let (dimension, depth_or_array_layers, view_dimension) = match (t.dimension, t.layers) {
            (3, _) => (wgpu::TextureDimension::D3, t.depth, wgpu::TextureViewDimension::D3),
            (_, 1) => (wgpu::TextureDimension::D2, 1, wgpu::TextureViewDimension::D2),
            (_, l) => (wgpu::TextureDimension::D2, l, wgpu::TextureViewDimension::D2Array),
        };
        let texture = self.device.create_texture_with_data(
            &self.queue,
            &wgpu::TextureDescriptor {
                label: Some(&t.name),
                size: wgpu::Extent3d {
                    width: t.width,
                    height: t.height,
                    depth_or_array_layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &bytes,
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(view_dimension),
            ..Default::default()
        });
        Ok(GpuTexture {
            _texture: texture,
            wgsl_type: wgsl_texture_type(t),
            view,
            view_dimension,
            filterable: storage == Storage::F16 || self.float32_filterable,
        })
    }

    /// Runs `entry` of the WGSL `source` over `count` items: bindings (group 0) are
    /// 0: the uniform `params` bytes, 1: `texture`, 2: a linear clamp-to-edge sampler,
    /// 3: the f32 `inputs` (read-only storage), 4: the f32 outputs (`count · n_out`),
    /// 5: a uniform vec4<u32> with `count` in x. Workgroups of 64.
    pub fn run(
        &self,
        source: &str,
        params: &[u8],
        texture: &GpuTexture,
        inputs: &[f32],
        count: usize,
        n_out: usize,
    ) -> Result<Vec<f32>, String> {
        self.run_with(source, params, texture, None, inputs, count, n_out)
    }

    /// [`Gpu::run`] with a second texture and its uniform parameters: bindings 6 (the
    /// uniform) and 7 (the texture; same filterability as the first, one sampler).
    #[allow(clippy::too_many_arguments)]
    pub fn run_with(
        &self,
        source: &str,
        params: &[u8],
        texture: &GpuTexture,
        second: Option<(&[u8], &GpuTexture)>,
        inputs: &[f32],
        count: usize,
        n_out: usize,
    ) -> Result<Vec<f32>, String> {
        let mut textures = vec![(params, texture)];
        textures.extend(second);
        self.run_textures(source, &textures, inputs, count, n_out)
    }

    /// [`Gpu::run`] with any number of textures (at least one), each with its uniform
    /// parameters: the first at bindings 0 and 1, texture k ≥ 1 at 4 + 2k (the uniform)
    /// and 5 + 2k (the texture); all of one filterability (one sampler).
    pub fn run_textures(
        &self,
        source: &str,
        textures: &[(&[u8], &GpuTexture)],
        inputs: &[f32],
        count: usize,
        n_out: usize,
    ) -> Result<Vec<f32>, String> {
        let Some(&(params, texture)) = textures.first() else {
            return Err("run_textures: no texture".into());
        };
        let extra = &textures[1..];
        let d = &self.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lobefit kernel"),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(source)),
        });
        let layout_entries = layout_entries(texture, extra)?;
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &layout_entries,
        });
        let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("lobefit kernel"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let filter = if texture.filterable {
            wgpu::FilterMode::Linear
        } else {
            wgpu::FilterMode::Nearest
        };
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: filter,
            min_filter: filter,
            ..Default::default()
        });
        let usage_in = wgpu::BufferUsages::STORAGE;
        // Storage buffers may not be empty.
        let mut input_data = inputs.to_vec();
        input_data.push(0.0);
        let params_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: params,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let in_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&input_data),
            usage: usage_in,
        });
        let out_size = ((count * n_out).max(1) * 4) as u64;
        let out_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let count_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&[count as u32, 0, 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let extra_bufs: Vec<wgpu::Buffer> = extra
            .iter()
            .map(|(p, _)| {
                d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: None,
                    contents: p,
                    usage: wgpu::BufferUsages::UNIFORM,
                })
            })
            .collect();
        let mut bind_entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: params_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&texture.view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: in_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: out_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: count_buf.as_entire_binding(),
            },
        ];
        for ((k, (_, t)), buf) in (1u32..).zip(extra).zip(&extra_bufs) {
            bind_entries.push(wgpu::BindGroupEntry {
                binding: 4 + 2 * k,
                resource: buf.as_entire_binding(),
            });
            bind_entries.push(wgpu::BindGroupEntry {
                binding: 5 + 2 * k,
                resource: wgpu::BindingResource::TextureView(&t.view),
            });
        }
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &bind_entries,
        });
        self.dispatch_and_read(&pipeline, &bind, &out_buf, out_size, scope, count, n_out)
    }

    /// Dispatches `pipeline` over `count` invocations (64 per workgroup), then reads
    /// the `count × n_out` outputs back from `out_buf` (`out_size` bytes); a validation
    /// error of the kernel (the open `scope`) is the error.
    #[allow(clippy::too_many_arguments)]
    fn dispatch_and_read(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bind: &wgpu::BindGroup,
        out_buf: &wgpu::Buffer,
        out_size: u64,
        scope: wgpu::ErrorScopeGuard,
        count: usize,
        n_out: usize,
    ) -> Result<Vec<f32>, String> {
        let d = &self.device;
        let read_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(64).max(1), 1, 1);
        }
        enc.copy_buffer_to_buffer(out_buf, 0, &read_buf, 0, out_size);
        self.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("wgpu: {e}"));
        }
        let slice = read_buf.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        d.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("wgpu poll: {e}"))?;
        let data = slice.get_mapped_range().map_err(|e| format!("wgpu map: {e}"))?;
        let out: Vec<f32> = bytemuck::cast_slice(&data).to_vec();
        drop(data);
        read_buf.unmap();
        Ok(out[..count * n_out].to_vec())
    }
}

/// The kernel's bind group layout: its parameters, first texture and sampler, input,
/// output and count (bindings 0–5), then per further texture its parameters and the
/// texture (6, 7, …).
fn layout_entries(
    texture: &GpuTexture,
    extra: &[(&[u8], &GpuTexture)],
) -> Result<Vec<wgpu::BindGroupLayoutEntry>, String> {
    let cs = wgpu::ShaderStages::COMPUTE;
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: cs,
        ty,
        count: None,
    };
    let uniform = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    let storage = |read_only| wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    let tex_entry = |t: &GpuTexture| wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float {
            filterable: t.filterable,
        },
        view_dimension: t.view_dimension,
        multisampled: false,
    };
    let mut layout_entries = vec![
        entry(0, uniform),
        entry(
            1,
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float {
                    filterable: texture.filterable,
                },
                view_dimension: texture.view_dimension,
                multisampled: false,
            },
        ),
        entry(
            2,
            wgpu::BindingType::Sampler(if texture.filterable {
                wgpu::SamplerBindingType::Filtering
            } else {
                wgpu::SamplerBindingType::NonFiltering
            }),
        ),
        entry(3, storage(true)),
        entry(4, storage(false)),
        entry(5, uniform),
    ];
    for (k, (_, t)) in (1u32..).zip(extra) {
        if t.filterable != texture.filterable {
            return Err("run_textures: the textures differ in filterability".into());
        }
        layout_entries.push(entry(4 + 2 * k, uniform));
        layout_entries.push(entry(5 + 2 * k, tex_entry(t)));
    }
    Ok(layout_entries)
}
