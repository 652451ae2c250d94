//! Which GPU a run uses: the high-performance adapter by default (discrete before integrated
//! before virtual before a CPU implementation such as lavapipe), or the first whose name
//! contains `--gpu-adapter NAME` (case-insensitive). Vulkan only.

use super::GpuError;
use serde::{Deserialize, Serialize};

/// What a run records about its GPU (run metadata and CSV columns).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GpuInfo {
    /// Adapter name as the driver reports it (`llvmpipe (LLVM 15.0.6, 256 bits)`, …).
    pub name: String,
    /// Driver name and version (`llvmpipe`, `Mesa 22.3.6`, …).
    pub driver: String,
    /// wgpu backend (`vulkan`).
    pub backend: String,
    /// Device type (`Cpu`, `DiscreteGpu`, …).
    pub device_type: String,
}

/// An open device: what every dispatch goes through.
#[derive(Clone)]
pub struct GpuContext {
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter it was opened on.
    pub info: GpuInfo,
}

fn rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

/// Every Vulkan adapter of this machine, as (name, device type).
pub fn list_adapters() -> Vec<GpuInfo> {
    let adapters = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN));
    adapters.iter().map(|a| info_of(&a.get_info())).collect()
}

fn info_of(i: &wgpu::AdapterInfo) -> GpuInfo {
    let driver = if i.driver_info.is_empty() {
        i.driver.clone()
    } else {
        format!("{} {}", i.driver, i.driver_info)
    };
    GpuInfo {
        name: i.name.clone(),
        driver,
        backend: format!("{:?}", i.backend).to_lowercase(),
        device_type: format!("{:?}", i.device_type),
    }
}

impl GpuContext {
    /// Open the adapter `name` picks (`None`: the high-performance one). One-line errors: no
    /// adapter, none matching, or a device that will not open.
    pub fn open(name: Option<&str>) -> Result<Self, GpuError> {
        let instance = instance();
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        adapters.sort_by_key(|a| rank(a.get_info().device_type));
        let adapter = match name {
            None => adapters.swap_remove(0),
            Some(n) => {
                let want = n.to_lowercase();
                let found = adapters
                    .iter()
                    .map(|a| a.get_info().name)
                    .collect::<Vec<_>>()
                    .join(", ");
                let k = adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&want))
                    .ok_or_else(|| GpuError::AdapterNotFound {
                        name: n.to_string(),
                        found,
                    })?;
                adapters.swap_remove(k)
            }
        };
        let info = info_of(&adapter.get_info());
        // The adapter's own limits: the 1 M-triangle scene's buffers exceed WebGPU's defaults.
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("raysched"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(Self {
            device,
            queue,
            info,
        })
    }
}
