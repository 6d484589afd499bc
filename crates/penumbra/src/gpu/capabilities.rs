//! What an adapter can do that penumbra's methods need, read once when the
//! device is created, so a method missing a capability is refused before
//! any work instead of failing on its first texture
//! or pipeline (llvmpipe GL cannot render to Rgba32Float, SSAO's G-buffer).

use crate::error::{Error, Result};
use crate::gpu::device::Needs;

/// Texture formats penumbra renders to (SSAO's G-buffer and its depth).
const RENDER_FORMATS: [wgpu::TextureFormat; 2] = [wgpu::TextureFormat::Rgba32Float, wgpu::TextureFormat::Depth32Float];

#[derive(Debug, Clone)]
pub struct Capabilities {
    pub compute: bool,
    pub storage_buffers_per_stage: u32,
    /// Of `RENDER_FORMATS`, those the device may use as render attachments.
    pub renderable: Vec<wgpu::TextureFormat>,
}

impl Capabilities {
    /// As wgpu validates: a downlevel adapter (GL) is asked for each
    /// format's usages; a WebGPU-compliant one has WebGPU's guarantees.
    pub fn of_adapter(adapter: &wgpu::Adapter, device: &wgpu::Device) -> Capabilities {
        let downlevel = adapter.get_downlevel_capabilities();
        let renderable = RENDER_FORMATS
            .into_iter()
            .filter(|&f| {
                let usages = match downlevel.is_webgpu_compliant() {
                    true => f.guaranteed_format_features(device.features()).allowed_usages,
                    false => adapter.get_texture_format_features(f).allowed_usages,
                };
                usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
            })
            .collect();
        Capabilities {
            compute: downlevel.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS),
            storage_buffers_per_stage: device.limits().max_storage_buffers_per_shader_stage,
            renderable,
        }
    }

    /// A host engine's device: WebGPU's guarantees (its adapter is the
    /// host's business).
    pub fn of_device(device: &wgpu::Device) -> Capabilities {
        Capabilities {
            compute: true,
            storage_buffers_per_stage: device.limits().max_storage_buffers_per_shader_stage,
            renderable: RENDER_FORMATS.to_vec(),
        }
    }

    /// `Ok` if `needs` are met; else a device error naming the method, the
    /// adapter (`label`: name and backend) and each missing capability.
    pub fn check(&self, needs: &Needs, label: &str) -> Result<()> {
        let mut missing = Vec::new();
        if !self.compute {
            missing.push("compute shaders".to_string());
        }
        let storage = needs.storage_buffers();
        if self.storage_buffers_per_stage < storage {
            missing.push(format!(
                "{storage} storage buffers per shader stage (it allows {})",
                self.storage_buffers_per_stage
            ));
        }
        for &(format, what) in needs.render_targets {
            if !self.renderable.contains(&format) {
                missing.push(format!("rendering to {format:?} textures ({what})"));
            }
        }
        if missing.is_empty() {
            return Ok(());
        }
        Err(Error::Device(format!(
            "{label} cannot run {} on the GPU: it lacks {}; use --device cpu, or another backend \
             (WGPU_BACKEND=vulkan, gl, ...)",
            needs.what,
            missing.join(", ")
        )))
    }
}
