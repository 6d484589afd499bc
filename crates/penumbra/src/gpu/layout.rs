//! Bind-group layout entries and bind groups, written once for every pass.

/// A storage buffer visible to compute shaders.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A uniform buffer visible to compute shaders.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    uniform_entry_for(binding, wgpu::ShaderStages::COMPUTE)
}

/// A uniform buffer visible to `stages`.
pub fn uniform_entry_for(binding: u32, stages: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: stages,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A float texture of `dimension` visible to compute shaders.
pub fn texture_entry(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
    filterable: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A write-only 2D storage texture of `format` visible to compute shaders.
pub fn storage_texture_entry(binding: u32, format: wgpu::TextureFormat) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// One binding of a pass's io bind group: what its layout declares and
/// which buffer the pass keeps for it (`buffers::KeptGroup::for_io`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Io {
    /// A storage buffer the kernel reads.
    In(u32, &'static str),
    /// A storage buffer the kernel writes.
    Out(u32, &'static str),
    /// A uniform of this many bytes.
    Uniform(u32, &'static str, u64),
}

impl Io {
    pub fn binding(self) -> u32 {
        match self {
            Io::In(b, _) | Io::Out(b, _) | Io::Uniform(b, _, _) => b,
        }
    }

    fn entry(self) -> wgpu::BindGroupLayoutEntry {
        match self {
            Io::In(b, _) => storage_entry(b, true),
            Io::Out(b, _) => storage_entry(b, false),
            Io::Uniform(b, _, _) => uniform_entry(b),
        }
    }
}

/// The layout of an io bind group.
pub fn io_layout(device: &wgpu::Device, label: &str, io: &[Io]) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = io.iter().map(|b| b.entry()).collect();
    layout(device, label, &entries)
}

/// A layout of `entries`.
pub fn layout(device: &wgpu::Device, label: &str, entries: &[wgpu::BindGroupLayoutEntry]) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    })
}

/// A bind group of whole buffers at the given bindings.
pub fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<_> = buffers
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}
