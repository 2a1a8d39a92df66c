//! A headless wgpu device on the Vulkan backend (lavapipe without a GPU), the exported
//! textures uploaded as GPU textures, and compute kernels run over input arrays.

use std::borrow::Cow;
use std::cell::RefCell;
use std::time::Instant;

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
    /// Whether the device writes timestamp queries (`Features::TIMESTAMP_QUERY`): the
    /// bench then times kernels on the device's clock, else by wall clock.
    pub timestamps: bool,
    /// llvmpipe's loop budget ([`crate::budget::LOOP_LIMIT`]) on a CPU adapter
    /// (lavapipe), `None` on a GPU: the renders refuse scenes over it.
    pub loop_budget: Option<u64>,
    /// Bench mode ([`Gpu::bench_frames`]): frames to time per dispatch, and what was
    /// timed.
    bench: RefCell<Option<(usize, Vec<Dispatched>)>>,
    /// Pipelines built so far, by source and bind group layout: a conformance run
    /// dispatches one kernel several times (each filter, each check), and on lavapipe
    /// building a pipeline (LLVM) costs more than running it. Only pipelines whose
    /// run passed validation are kept.
    pipelines: RefCell<PipelineCache>,
}

/// See [`Gpu`]'s `pipelines`.
type PipelineCache = std::collections::HashMap<
    (String, Vec<wgpu::BindGroupLayoutEntry>),
    (wgpu::BindGroupLayout, wgpu::ComputePipeline),
>;

/// One kernel timed in bench mode: its source, items and per-frame times.
#[derive(Debug, Clone)]
pub struct Dispatched {
    /// The WGSL it ran.
    pub source: String,
    /// Invocations per frame (pixels).
    pub count: usize,
    /// Milliseconds per frame, one per timed frame.
    pub ms: Vec<f64>,
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
        Gpu::open(false)
    }

    /// [`Gpu::new`], asking for timestamp queries where the adapter has them (the
    /// bench's clock). Only the bench asks: no other run reads the device's clock.
    pub fn with_timestamps() -> Result<Gpu, String> {
        Gpu::open(true)
    }

    fn open(want_timestamps: bool) -> Result<Gpu, String> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            // No shader debug info, which a build with debug assertions (ours: the dev
            // profile) asks for by default: naga's SPIR-V writer then finds each
            // statement's line by counting newlines from the top of the source, which is
            // quadratic in our generated kernels (up to 170 kB) and took a quarter of a
            // gpu-check's time. Validation stays as the build configures it.
            flags: wgpu::InstanceFlags::from_build_config().difference(wgpu::InstanceFlags::DEBUG),
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
        let timestamps = want_timestamps && adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut required_features = wgpu::Features::empty();
        if float32_filterable {
            required_features |= wgpu::Features::FLOAT32_FILTERABLE;
        }
        if timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lobefit-gpu"),
            required_features,
            required_limits: wgpu::Limits::default(),
            ..Default::default()
        }))
        .map_err(|e| format!("Vulkan adapter {:?}: cannot create a device: {e}", info.name))?;
        Ok(Gpu {
            loop_budget: (info.device_type == wgpu::DeviceType::Cpu).then_some(crate::budget::LOOP_LIMIT),
            info,
            device,
            queue,
            float32_filterable,
            timestamps,
            bench: RefCell::new(None),
            pipelines: RefCell::default(),
        })
    }

    /// Whether the device was created with timestamp queries (whatever
    /// [`Gpu::timestamps`] now says).
    pub fn has_timestamp_queries(&self) -> bool {
        self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Bench mode: from now on every kernel run also dispatches itself once more
    /// untimed (warm-up, after the run that compiled it) and then `frames` times timed
    /// (timestamp queries where [`Gpu::timestamps`], else wall clock around submit and
    /// wait), recorded for [`Gpu::take_dispatches`]. The run's results are those of its
    /// first dispatch, as without bench mode.
    pub fn bench_frames(&self, frames: usize) {
        *self.bench.borrow_mut() = Some((frames, Vec::new()));
    }

    /// The kernels timed since [`Gpu::bench_frames`] (bench mode stays on).
    pub fn take_dispatches(&self) -> Vec<Dispatched> {
        self.bench
            .borrow_mut()
            .as_mut()
            .map(|(_, d)| std::mem::take(d))
            .unwrap_or_default()
    }

    /// How [`Gpu::take_dispatches`]'s times are measured, for the report.
    pub fn timing_source(&self) -> &'static str {
        if self.timestamps {
            "timestamp queries (TIMESTAMP_QUERY, compute pass begin to end)"
        } else {
            "wall clock around submit + poll(wait)"
        }
    }

    /// Dispatches `pipeline` over `count` invocations alone and returns its time in ms:
    /// the timestamps of the pass's beginning and end where the device has them, else
    /// the wall clock from submit to the end of the wait.
    fn time_dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bind: &wgpu::BindGroup,
        count: usize,
    ) -> Result<f64, String> {
        let d = &self.device;
        let queries = self.timestamps.then(|| {
            d.create_query_set(&wgpu::QuerySetDescriptor {
                label: None,
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            })
        });
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: None,
                timestamp_writes: queries.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(64).max(1), 1, 1);
        }
        let read = queries.as_ref().map(|q| {
            let resolve = d.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = d.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            enc.resolve_query_set(q, 0..2, &resolve, 0);
            enc.copy_buffer_to_buffer(&resolve, 0, &read, 0, 16);
            read
        });
        let t = Instant::now();
        self.queue.submit([enc.finish()]);
        d.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("wgpu poll: {e}"))?;
        let wall = t.elapsed().as_secs_f64() * 1e3;
        let Some(read) = read else { return Ok(wall) };
        let slice = read.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        d.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("wgpu poll: {e}"))?;
        let data = slice.get_mapped_range().map_err(|e| format!("wgpu map: {e}"))?;
        let ticks: [u64; 2] = [
            u64::from_le_bytes(data[0..8].try_into().map_err(|_| "timestamp readback")?),
            u64::from_le_bytes(data[8..16].try_into().map_err(|_| "timestamp readback")?),
        ];
        drop(data);
        read.unmap();
        if ticks[1] < ticks[0] {
            return Err(format!(
                "timestamp queries: end {} before beginning {}",
                ticks[1], ticks[0]
            ));
        }
        Ok((ticks[1] - ticks[0]) as f64 * f64::from(self.queue.get_timestamp_period()) * 1e-6)
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
        let key = (source.to_string(), layout_entries(texture, extra)?);
        let cached = self.pipelines.borrow().get(&key).cloned();
        let (layout, pipeline) = match cached {
            Some(p) => p,
            None => self.compute_pipeline(source, &key.1)?,
        };
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
        // Storage buffers may not be empty.
        let mut input_data = inputs.to_vec();
        input_data.push(0.0);
        let params_buf = self.uniform(params);
        let in_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&input_data),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let out_size = ((count * n_out).max(1) * 4) as u64;
        let out_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        // The count (and the 0 that `budget::SENTINEL` reads) in a storage buffer, not
        // a uniform one: lavapipe inlines a uniform that a branch or a loop bound reads
        // and compiles a variant of the kernel per value (measured: the same kernel at
        // 101 and 102 pixels compiled twice, ~9 s each), which would also let it see
        // the sentinel's bound.
        let count_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&[count as u32, 0, 0, 0]),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let extra_bufs: Vec<wgpu::Buffer> = extra.iter().map(|(p, _)| self.uniform(p)).collect();
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
        let out = self.dispatch_and_read(&pipeline, &bind, &out_buf, out_size, scope, count, n_out)?;
        self.bench_dispatch(source, &pipeline, &bind, count)?;
        self.pipelines.borrow_mut().entry(key).or_insert((layout, pipeline));
        Ok(out)
    }

    /// The compute pipeline of `source` (entry point `main`) and its bind group layout
    /// of `layout_entries` (see [`Gpu::run_textures`]).
    fn compute_pipeline(
        &self,
        source: &str,
        layout_entries: &[wgpu::BindGroupLayoutEntry],
    ) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), String> {
        let d = &self.device;
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lobefit kernel"),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(source)),
        });
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: layout_entries,
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
        Ok((layout, pipeline))
    }

    /// Kernels (compute pipelines) built so far and kept: what an animation reads to
    /// show that its frames after the first build none.
    pub fn kernels_built(&self) -> usize {
        self.pipelines.borrow().len()
    }

    /// A uniform buffer holding `contents`.
    fn uniform(&self, contents: &[u8]) -> wgpu::Buffer {
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents,
            usage: wgpu::BufferUsages::UNIFORM,
        })
    }

    /// When the bench is recording (`lobefit-gpu bench`): one untimed dispatch, then
    /// its frames timed, kept with the kernel's source.
    fn bench_dispatch(
        &self,
        source: &str,
        pipeline: &wgpu::ComputePipeline,
        bind: &wgpu::BindGroup,
        count: usize,
    ) -> Result<(), String> {
        let frames = self.bench.borrow().as_ref().map(|(f, _)| *f);
        let Some(frames) = frames else {
            return Ok(());
        };
        self.time_dispatch(pipeline, bind, count)?;
        let ms = (0..frames)
            .map(|_| self.time_dispatch(pipeline, bind, count))
            .collect::<Result<Vec<f64>, String>>()?;
        if let Some((_, d)) = self.bench.borrow_mut().as_mut() {
            d.push(Dispatched {
                source: source.to_string(),
                count,
                ms,
            });
        }
        Ok(())
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
        entry(5, storage(true)),
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
