//! The GPU path tracer (feature `gpu`): a WGSL port of `render::integrator` run through wgpu on
//! Vulkan, one invocation per pixel, one dispatch per hand-out.
//!
//! - [`device`]: adapter choice (high-performance first, or `--gpu-adapter NAME`) and what a
//!   run records about it ([`GpuInfo`]).
//! - [`upload`]: the scene as the kernel's buffers (the native tracer's BVH build, as a
//!   compressed 8-wide BVH or the binary baseline: [`BvhLayout`]).
//! - [`counters`]: per-ray traversal work (node fetches, bytes, box and primitive tests, stack
//!   depth), counted by the kernel's debug pipeline and by the same traversal on the CPU.
//! - [`GpuRenderer`]: the scene on one device; [`GpuRenderer::submit`] encodes a set of pixel
//!   tasks as one dispatch and returns a [`Dispatch`] whose results arrive when its readback
//!   buffer is mapped.
//!
//! The kernel draws the same random numbers as the CPU (the SplitMix64 key of `rng.rs`,
//! emulated in u32 pairs: bit-identical, tested), follows the same paths and rules, but rounds
//! differently (FMA contraction, transcendental functions, spheres in f32 instead of f64), so
//! a GPU image estimates the same samples without being bit-identical to the CPU image.

pub mod counters;
pub mod device;
pub mod upload;
mod wgsl_math;

pub use device::{GpuContext, GpuInfo};
pub use upload::BvhLayout;

use crate::core::render::{TileResult, WorkItem};
use crate::core::scene::Scene;
use std::sync::mpsc;
use upload::{scene_buffers_with, SceneBuffers, PIXEL_OUT_BYTES};
use wgpu::util::DeviceExt;

/// Why the GPU path cannot run: every variant prints as one line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// No Vulkan adapter at all.
    #[error("no Vulkan GPU adapter found (install a Vulkan driver, e.g. Debian's mesa-vulkan-drivers for lavapipe)")]
    NoAdapter,
    /// `--gpu-adapter NAME` matched no adapter.
    #[error("--gpu-adapter {name}: no Vulkan adapter matches (found: {found})")]
    AdapterNotFound {
        /// The name asked for.
        name: String,
        /// The adapters there are, comma-separated.
        found: String,
    },
    /// The device refused to open.
    #[error("gpu: opening the device failed: {0}")]
    Device(String),
    /// The scene uses something the kernel cannot render exactly as the CPU does.
    #[error("gpu: scene not supported: {0}")]
    Unsupported(String),
    /// A buffer would exceed the device's limits.
    #[error("gpu: {what} needs {bytes} bytes, above the device's limit of {limit}")]
    TooLarge {
        /// Which buffer.
        what: &'static str,
        /// Its size.
        bytes: u64,
        /// The device's limit.
        limit: u64,
    },
    /// Validation, mapping or device loss while running.
    #[error("gpu: {0}")]
    Runtime(String),
}

/// What the kernel runs per task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// The path tracer: every sample of one pixel.
    Render,
    /// The first 8 random numbers of the stream (pixel, sample) = the task.
    RngProbe,
    /// Nothing: the fixed cost of one dispatch.
    Empty,
    /// The debug pipeline: one CPU-made ray per task, traced with counters
    /// ([`GpuRenderer::count_rays`]).
    Count,
}

/// One pixel's result from the kernel: the sum of its finite samples and its counters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelOut {
    /// Sum of the finite samples (f32 on the device).
    pub sum: [f32; 3],
    /// Samples dropped as NaN or infinite.
    pub nonfinite: u32,
    /// Tracer queries (closest-hit and shadow).
    pub rays: u32,
    /// Finite samples summed.
    pub finite: u32,
    /// Unused by [`Entry::Render`]; the last two probe words for [`Entry::RngProbe`].
    pub extra: [u32; 2],
}

impl PixelOut {
    fn parse(b: &[u8]) -> Self {
        let w = |k: usize| u32::from_le_bytes(b[4 * k..4 * k + 4].try_into().expect("4 bytes"));
        Self {
            sum: [0, 1, 2].map(|k| f32::from_bits(w(k))),
            nonfinite: w(3),
            rays: w(4),
            finite: w(5),
            extra: [w(6), w(7)],
        }
    }
    /// The eight words as written (the RNG probe's eight f32s).
    pub fn words(&self) -> [u32; 8] {
        [
            self.sum[0].to_bits(),
            self.sum[1].to_bits(),
            self.sum[2].to_bits(),
            self.nonfinite,
            self.rays,
            self.finite,
            self.extra[0],
            self.extra[1],
        ]
    }
}

/// The kernel: the path tracer and its traversals, one WGSL module.
pub const KERNEL_SOURCE: &str =
    concat!(include_str!("path.wgsl"), "\n", include_str!("cwbvh.wgsl"));

const WORKGROUP: u32 = 64;
const MAX_GROUPS_X: u32 = 65_535;

/// A scene on one device, ready for dispatches. `Send + Sync`: one renderer serves a source's
/// thread and the tests alike.
pub struct GpuRenderer {
    ctx: GpuContext,
    layout: wgpu::BindGroupLayout,
    render: wgpu::ComputePipeline,
    probe: wgpu::ComputePipeline,
    empty: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    scene_bufs: [wgpu::Buffer; 8],
    layout_kind: BvhLayout,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
    frames: u32,
    n_nodes: u32,
    n_lights: u32,
    env: [f32; 3],
    has_env: bool,
    origin: [f32; 3],
    /// Most tasks one dispatch may carry (its output buffer within the binding limit).
    pub max_tasks: u32,
}

/// A submitted dispatch: its results arrive once [`GpuRenderer::wait`] sees the readback
/// buffer mapped.
pub struct Dispatch {
    readback: wgpu::Buffer,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
    submission: wgpu::SubmissionIndex,
    tasks: usize,
}

impl Dispatch {
    /// Tasks (pixels) in this dispatch.
    pub fn tasks(&self) -> usize {
        self.tasks
    }
}

impl GpuRenderer {
    /// Upload `scene` to the device of `ctx` with the default (wide) BVH and build the
    /// kernel's pipelines. Errors are one line; nothing is allocated on the device before the
    /// sizes are checked.
    pub fn new(ctx: GpuContext, scene: &Scene) -> Result<Self, GpuError> {
        Self::with_layout(ctx, scene, BvhLayout::default())
    }

    /// [`GpuRenderer::new`] with the BVH layout `layout`.
    pub fn with_layout(
        ctx: GpuContext,
        scene: &Scene,
        layout: BvhLayout,
    ) -> Result<Self, GpuError> {
        Self::with_buffers(ctx, scene, &scene_buffers_with(scene, layout)?)
    }

    /// [`GpuRenderer::new`] from buffers laid out already (`bufs` must be of `scene`).
    pub fn with_buffers(
        ctx: GpuContext,
        scene: &Scene,
        bufs: &SceneBuffers,
    ) -> Result<Self, GpuError> {
        let limits = ctx.device.limits();
        let bind_limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        for (what, b) in [
            ("the BVH", &bufs.nodes),
            ("the primitives", &bufs.prims),
            ("the area-light table", &bufs.light_prims),
            ("the cameras", &bufs.cams),
            ("the wide primitives", &bufs.wide_prims),
        ] {
            if b.len() as u64 > bind_limit {
                return Err(GpuError::TooLarge {
                    what,
                    bytes: b.len() as u64,
                    limit: bind_limit,
                });
            }
        }
        let device = &ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("raysched path tracer"),
            source: wgpu::ShaderSource::Wgsl(KERNEL_SOURCE.into()),
        });
        let layout = kernel_layout(device);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raysched kernel"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let wide = if bufs.layout == BvhLayout::Wide {
            1.0
        } else {
            0.0
        };
        let pipeline = |entry: &str, count: f64| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("WIDE", wide), ("COUNT", count)],
                    ..Default::default()
                },
                cache: None,
            })
        };
        let (render, probe, empty) = (
            pipeline("render", 0.0),
            pipeline("rng_probe", 0.0),
            pipeline("empty", 0.0),
        );
        let count = pipeline("count_rays", 1.0);
        let scene_bufs = upload_scene(device, bufs);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Runtime(first_line(&e.to_string())));
        }
        let max_depth = if scene.settings.max_depth < 0 {
            crate::util::limits::MAX_DEPTH
        } else {
            scene.settings.max_depth as u32
        };
        let env = scene.environment_radiance().to_array();
        let max_tasks = (bind_limit / PIXEL_OUT_BYTES).min(u32::MAX as u64) as u32;
        Ok(Self {
            layout,
            render,
            probe,
            empty,
            count,
            scene_bufs,
            layout_kind: bufs.layout,
            width: scene.width(),
            height: scene.height(),
            spp: scene.settings.spp,
            max_depth,
            frames: scene.frames(),
            n_nodes: bufs.n_nodes,
            n_lights: bufs.n_lights,
            env,
            has_env: scene.environment.is_some(),
            origin: scene.origin.as_vec3().to_array(),
            max_tasks,
            ctx,
        })
    }

    /// The BVH layout the kernel traverses.
    pub fn layout(&self) -> BvhLayout {
        self.layout_kind
    }

    /// The adapter this renderer runs on.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    /// The pixel tasks of `items`: (pixel index, frame), in item order then pixel order.
    pub fn tasks_of(&self, items: &[WorkItem]) -> Vec<[u32; 2]> {
        let mut tasks = Vec::with_capacity(items.iter().map(|i| i.pixel_count()).sum());
        for it in items {
            tasks.extend(it.pixels(self.width).map(|p| [p, it.frame]));
        }
        tasks
    }

    /// Encode `tasks` as one dispatch of `entry`, submit it and ask for its readback buffer to
    /// be mapped. Returns at once. Tasks must name pixels and frames of the scene (checked).
    pub fn submit(&self, tasks: &[[u32; 2]], entry: Entry) -> Result<Dispatch, GpuError> {
        let n = tasks.len().max(1);
        if n as u64 > self.max_tasks as u64 {
            return Err(GpuError::TooLarge {
                what: "one dispatch's output",
                bytes: n as u64 * PIXEL_OUT_BYTES,
                limit: self.max_tasks as u64 * PIXEL_OUT_BYTES,
            });
        }
        let pixels = self.width * self.height;
        if entry == Entry::Render {
            if let Some(t) = tasks.iter().find(|t| t[0] >= pixels || t[1] >= self.frames) {
                return Err(GpuError::Runtime(format!(
                    "task (pixel {}, frame {}) outside the scene's {pixels} pixels × {} frames",
                    t[0], t[1], self.frames
                )));
            }
        }
        // A count dispatch's tasks are rays: four (u32, u32) pairs each.
        let n_tasks = if entry == Entry::Count {
            tasks.len() / 4
        } else {
            tasks.len()
        };
        let device = &self.ctx.device;
        let params = self.params(n_tasks);
        let mut task_bytes = Vec::with_capacity(n * 8);
        for t in tasks {
            task_bytes.extend_from_slice(&t[0].to_le_bytes());
            task_bytes.extend_from_slice(&t[1].to_le_bytes());
        }
        task_bytes.resize(n * 8, 0);
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: &params,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let task_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("tasks"),
            contents: &task_bytes,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let out_size = n_tasks.max(1) as u64 * PIXEL_OUT_BYTES;
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("out"),
            size: out_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: out_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = self.bind_group(&uniform, &task_buf, &out);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("dispatch"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("dispatch"),
                timestamp_writes: None,
            });
            pass.set_pipeline(match entry {
                Entry::Render => &self.render,
                Entry::RngProbe => &self.probe,
                Entry::Empty => &self.empty,
                Entry::Count => &self.count,
            });
            pass.set_bind_group(0, &bind, &[]);
            let groups = (n_tasks as u32).div_ceil(WORKGROUP).max(1);
            let (x, y) = if entry == Entry::Empty {
                (1, 1)
            } else if groups <= MAX_GROUPS_X {
                (groups, 1)
            } else {
                (MAX_GROUPS_X, groups.div_ceil(MAX_GROUPS_X))
            };
            pass.dispatch_workgroups(x, y, 1);
        }
        enc.copy_buffer_to_buffer(&out, 0, &readback, 0, out_size);
        let submission = self.ctx.queue.submit([enc.finish()]);
        let (tx, rx) = mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Ok(Dispatch {
            readback,
            mapped: rx,
            submission,
            tasks: n_tasks,
        })
    }

    /// The uniform block of a dispatch of `n_tasks` tasks.
    fn params(&self, n_tasks: usize) -> Vec<u8> {
        let mut params = Vec::with_capacity(64);
        for w in [
            self.width,
            self.spp,
            self.max_depth,
            n_tasks as u32,
            self.n_lights,
            self.has_env as u32,
            self.n_nodes,
            self.height,
        ] {
            params.extend_from_slice(&w.to_le_bytes());
        }
        for x in self
            .env
            .iter()
            .chain(&[0.0])
            .chain(&self.origin)
            .chain(&[0.0])
        {
            params.extend_from_slice(&x.to_le_bytes());
        }
        params
    }

    /// A dispatch's bindings: its uniforms, the scene's buffers, its tasks and its output.
    fn bind_group(
        &self,
        uniform: &wgpu::Buffer,
        task_buf: &wgpu::Buffer,
        out: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        for (k, b) in self.scene_bufs.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                // The wide nodes and primitives, last of the scene's buffers, are bindings 9, 10.
                binding: if k >= 6 { k as u32 + 3 } else { k as u32 + 1 },
                resource: b.as_entire_binding(),
            });
        }
        entries.push(wgpu::BindGroupEntry {
            binding: 7,
            resource: task_buf.as_entire_binding(),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: 8,
            resource: out.as_entire_binding(),
        });
        self.ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("dispatch"),
                layout: &self.layout,
                entries: &entries,
            })
    }

    /// Block until `d` is done and its buffer mapped; its per-task results in task order.
    pub fn wait(&self, d: Dispatch) -> Result<Vec<PixelOut>, GpuError> {
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(d.submission),
                timeout: None,
            })
            .map_err(|e| GpuError::Runtime(first_line(&e.to_string())))?;
        let mapped = loop {
            match d.mapped.try_recv() {
                Ok(r) => break r,
                Err(mpsc::TryRecvError::Empty) => {
                    // The callback runs inside a poll; one more blocking poll delivers it.
                    let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
                    if let Ok(r) = d.mapped.recv_timeout(std::time::Duration::from_millis(100)) {
                        break r;
                    }
                }
                Err(mpsc::TryRecvError::Disconnected) => {
                    return Err(GpuError::Runtime("readback mapping was dropped".into()))
                }
            }
        };
        mapped.map_err(|e| GpuError::Runtime(format!("mapping the results: {e}")))?;
        let out = {
            let view = d
                .readback
                .get_mapped_range(..)
                .map_err(|e| GpuError::Runtime(format!("reading the results: {e}")))?;
            view.chunks_exact(PIXEL_OUT_BYTES as usize)
                .take(d.tasks)
                .map(PixelOut::parse)
                .collect()
        };
        d.readback.unmap();
        Ok(out)
    }

    /// Render `items` in one dispatch and wait for them: the blocking form the tests use.
    pub fn render_items(&self, items: &[WorkItem]) -> Result<Vec<TileResult>, GpuError> {
        let d = self.submit(&self.tasks_of(items), Entry::Render)?;
        let px = self.wait(d)?;
        Ok(self.results(items, &px))
    }

    /// Split a dispatch's per-pixel results back into one [`TileResult`] per item: each pixel
    /// the mean of its samples (sum ÷ spp, as `render_item` divides).
    pub fn results(&self, items: &[WorkItem], px: &[PixelOut]) -> Vec<TileResult> {
        let inv = 1.0 / self.spp as f64;
        let mut at = 0;
        items
            .iter()
            .map(|it| {
                let n = it.pixel_count();
                let slice = &px[at..at + n];
                at += n;
                TileResult {
                    item: it.id,
                    pixels: slice
                        .iter()
                        .map(|p| p.sum.map(|s| (s as f64 * inv) as f32))
                        .collect(),
                    rays: slice.iter().map(|p| p.rays as u64).sum(),
                    nonfinite: slice.iter().map(|p| p.nonfinite as u64).sum(),
                }
            })
            .collect()
    }

    /// Trace `rays` with the kernel's debug pipeline (`COUNT = true`): each ray's counts and
    /// hit, in ray order, to compare with [`counters::cpu_counts`]. Large sets go in several
    /// dispatches.
    pub fn count_rays(
        &self,
        rays: &[counters::CountRay],
    ) -> Result<Vec<counters::Counted>, GpuError> {
        let mut out = Vec::with_capacity(rays.len());
        // Whole workgroups a dispatch, so ray k sits in lane k % 64 as `cpu_counts` assumes.
        let lanes = upload::WORKGROUP_LANES;
        let per = (self.max_tasks as usize / 4 / lanes).clamp(1, (1 << 18) / lanes) * lanes;
        for chunk in rays.chunks(per) {
            let words: Vec<[u32; 2]> = chunk.iter().flat_map(|r| r.words()).collect();
            let d = self.submit(&words, Entry::Count)?;
            out.extend(self.wait(d)?.iter().map(|p| counters::Counted {
                counts: counters::RayCounts {
                    node_fetches: p.nonfinite,
                    bytes: p.rays,
                    box_tests: p.finite,
                    tri_tests: p.extra[0],
                    max_stack: p.extra[1],
                },
                hit: (p.sum[1] > 0.0).then(|| (p.sum[0], p.sum[1] as u32 - 1)),
            }));
        }
        Ok(out)
    }

    /// The first 8 random numbers of each stream (pixel, sample) of `keys` under frame 0's
    /// seed, as f32 bits: what the RNG identity test compares with `rng::Sampler`.
    pub fn rng_probe(&self, keys: &[[u32; 2]]) -> Result<Vec<[u32; 8]>, GpuError> {
        let d = self.submit(keys, Entry::RngProbe)?;
        Ok(self.wait(d)?.iter().map(|p| p.words()).collect())
    }
}

fn first_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("unknown error")
        .to_string()
}

/// The kernel's bindings: the uniforms (0), the scene's read-only buffers (1–6, 9, 10) and
/// the outputs (7, 8).
fn kernel_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let storage = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }];
    entries.extend((1..=6).map(|b| storage(b, true)));
    entries.push(storage(7, false));
    entries.push(storage(8, false));
    entries.push(storage(9, true));
    entries.push(storage(10, true));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("raysched kernel"),
        entries: &entries,
    })
}

/// The scene's buffers on the device, in binding order; the BVH layout not traversed gets a
/// placeholder (every binding needs a buffer).
fn upload_scene(device: &wgpu::Device, bufs: &SceneBuffers) -> [wgpu::Buffer; 8] {
    let init = |label: &str, contents: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    // The layout not traversed gets a placeholder: every binding needs a buffer.
    let placeholder = [0u8; 480];
    let (binary_nodes, wide_nodes) = match bufs.layout {
        BvhLayout::Binary => (&bufs.nodes[..], &placeholder[..]),
        BvhLayout::Wide => (&placeholder[..], &bufs.nodes[..]),
    };
    [
        init("nodes", binary_nodes),
        init("prims", &bufs.prims),
        init("materials", &bufs.materials),
        init("lights", &bufs.lights),
        init("light_prims", &bufs.light_prims),
        init("cams", &bufs.cams),
        init("wide nodes", wide_nodes),
        init("wide prims", &bufs.wide_prims),
    ]
}

#[cfg(test)]
mod tests {
    use wgpu::naga;

    /// The kernel parses and validates without a device (a shader error reads in full here;
    /// the device's error scope keeps one line).
    #[test]
    fn the_kernel_parses_and_validates() {
        let src = super::KERNEL_SOURCE;
        let module = naga::front::wgsl::parse_str(src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    }
}
