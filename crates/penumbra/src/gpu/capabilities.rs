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
            renderable,
        }
    }

    /// A host engine's device: WebGPU's guarantees (its adapter is the
    /// host's business).
    pub fn webgpu() -> Capabilities {
        Capabilities {
            compute: true,
            renderable: RENDER_FORMATS.to_vec(),
        }
    }

    /// `Ok` if `needs` are met on a device with these capabilities and
    /// `limits` (what it was created with, not what its adapter could have
    /// given); else a device error naming the method, the adapter (`label`:
    /// name and backend) and each missing capability or exceeded limit.
    pub fn check(&self, needs: &Needs, limits: &wgpu::Limits, label: &str) -> Result<()> {
        let mut missing = Vec::new();
        if !self.compute {
            missing.push("compute shaders".to_string());
        }
        missing.extend(needs.exceeded(limits).iter().map(ToString::to_string));
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

#[cfg(test)]
mod tests {
    use super::Capabilities;
    use crate::gpu::device::Needs;

    #[test]
    fn the_portable_limits_allow_every_method() {
        let portable = wgpu::Limits::default();
        for needs in [&Needs::COMPUTE, &Needs::SSAO] {
            Capabilities::webgpu().check(needs, &portable, "a host").unwrap();
        }
    }

    #[test]
    fn a_method_over_a_limit_is_refused_naming_it_what_it_needs_and_what_the_device_has() {
        let small = wgpu::Limits {
            max_compute_workgroup_storage_size: 8192,
            max_storage_buffers_per_shader_stage: 4,
            max_compute_invocations_per_workgroup: 32,
            ..wgpu::Limits::default()
        };
        let e = Capabilities::webgpu()
            .check(&Needs::SSAO, &small, "tiny (vulkan)")
            .unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let m = e.to_string();
        for part in [
            "tiny (vulkan) cannot run SSAO on the GPU",
            "8 storage buffers per shader stage for ssao_estimate (`max_storage_buffers_per_shader_stage` is 4)",
            "14848 bytes of workgroup memory for sh_transfer_portable (`max_compute_workgroup_storage_size` is 8192)",
            "64 invocations per workgroup for trace_rays (`max_compute_invocations_per_workgroup` is 32)",
        ] {
            assert!(m.contains(part), "{m}\nlacks: {part}");
        }
    }
}
