//! Buffer creation within the device's limits, buffers kept and grown
//! between calls, and blocking readback.

use wgpu::util::DeviceExt;

use crate::error::{Error, Result};

/// Checks that `bytes` fits one storage binding of `device`; `what` names the
/// data in the error.
pub fn check_storage_size(device: &wgpu::Device, what: &str, bytes: u64) -> Result<()> {
    let limits = device.limits();
    check_size(
        limits.max_storage_buffer_binding_size.min(limits.max_buffer_size),
        what,
        bytes,
    )
}

/// Checks that `bytes` fits one buffer of `device` (a read-back, a vertex
/// buffer); `what` names the data in the error.
pub fn check_buffer_size(device: &wgpu::Device, what: &str, bytes: u64) -> Result<()> {
    let max = device.limits().max_buffer_size;
    if bytes > max {
        return Err(Error::Device(format!(
            "{what} needs {:.1} MiB in one buffer; this device allows {:.1} MiB per buffer \
             (use `device` cpu, or a smaller input)",
            bytes as f64 / 1048576.0,
            max as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// `bytes` against a per-binding limit `max`.
pub fn check_size(max: u64, what: &str, bytes: u64) -> Result<()> {
    if bytes > max {
        return Err(Error::Device(format!(
            "{what} needs {:.1} MiB in one storage buffer; this device allows {:.1} MiB per binding \
             (use `device` cpu, or a smaller input)",
            bytes as f64 / 1048576.0,
            max as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// A read-only storage buffer holding `data` (at least 4 bytes: empty
/// bindings are not allowed).
pub fn storage_buffer(device: &wgpu::Device, label: &str, data: &[u8]) -> Result<wgpu::Buffer> {
    check_storage_size(device, label, data.len() as u64)?;
    let padded;
    let contents = if data.len() < 4 {
        padded = [0u8; 4];
        &padded[..]
    } else {
        data
    };
    Ok(device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    }))
}

/// An uninitialised (zeroed) buffer of `bytes` (rounded up to 4).
pub fn zeroed_buffer(device: &wgpu::Device, label: &str, bytes: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(4).next_multiple_of(4),
        usage,
        mapped_at_creation: false,
    })
}

/// A uniform buffer holding `value`, writable later (`COPY_DST`).
pub fn uniform_buffer<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, value: &T) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::bytes_of(value),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

/// Maps a MAP_READ buffer (after the copies into it were submitted), waits,
/// and returns its first `len` elements.
pub fn read_back<T: bytemuck::Pod>(device: &wgpu::Device, buffer: &wgpu::Buffer, len: usize) -> Result<Vec<T>> {
    let bytes = (len * std::mem::size_of::<T>()) as u64;
    if bytes == 0 {
        return Ok(Vec::new());
    }
    let slice = buffer.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    let waited = device.poll(wgpu::PollType::wait_indefinitely());
    super::context::take_device_error()?;
    waited.map_err(|e| Error::internal(format!("waiting for the GPU failed: {e}")))?;
    rx.recv()
        .map_err(|_| Error::internal("buffer mapping was dropped"))?
        .map_err(|e| Error::internal(format!("cannot map a readback buffer: {e}")))?;
    let out = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| Error::internal(format!("cannot read a mapped buffer: {e}")))?;
        bytemuck::cast_slice::<u8, T>(&view).to_vec()
    };
    buffer.unmap();
    Ok(out)
}

/// A buffer kept between calls and grown (never shrunk) when a request
/// needs more, so a pass reallocates, and rebuilds its bind groups, only
/// when its work gets larger (glyphon's `prepare` pattern).
pub struct GrowingBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buffer: Option<wgpu::Buffer>,
}

impl GrowingBuffer {
    /// An empty buffer (nothing allocated until `reserve`) of `usage`,
    /// `label` naming it in device errors and debuggers.
    pub const fn new(label: &'static str, usage: wgpu::BufferUsages) -> GrowingBuffer {
        GrowingBuffer {
            label,
            usage,
            buffer: None,
        }
    }

    /// Makes room for `bytes`; returns whether the buffer was (re)allocated.
    /// A storage buffer must fit one binding of the device.
    pub fn reserve(&mut self, device: &wgpu::Device, bytes: u64) -> Result<bool> {
        if self.buffer.as_ref().is_some_and(|b| b.size() >= bytes) {
            return Ok(false);
        }
        match self.usage.contains(wgpu::BufferUsages::STORAGE) {
            true => check_storage_size(device, self.label, bytes)?,
            false => check_buffer_size(device, self.label, bytes)?,
        }
        self.buffer = Some(zeroed_buffer(device, self.label, bytes, self.usage));
        Ok(true)
    }

    /// Writes `data` at the start of the buffer, growing it first; returns
    /// whether it was reallocated.
    pub fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) -> Result<bool> {
        let grown = self.reserve(device, data.len() as u64)?;
        if !data.is_empty() {
            queue.write_buffer(self.get(), 0, data);
        }
        Ok(grown)
    }

    /// The buffer (call `reserve` or `write` first).
    pub fn get(&self) -> &wgpu::Buffer {
        self.buffer.as_ref().expect("GrowingBuffer used before reserve")
    }
}

/// One binding of a `KeptGroup`.
pub enum Kept {
    /// Kept between calls, grown when a call needs more.
    Growing(GrowingBuffer),
    /// Fixed size (a uniform).
    Fixed(wgpu::Buffer),
}

impl Kept {
    /// A storage buffer the pass reads (uploaded by `write`).
    pub fn input(label: &'static str) -> Kept {
        Kept::Growing(GrowingBuffer::new(label, STORAGE_IN))
    }

    /// A storage buffer the pass writes, copied out (or cleared) after it.
    pub fn output(label: &'static str) -> Kept {
        Kept::Growing(GrowingBuffer::new(label, STORAGE_IN | wgpu::BufferUsages::COPY_SRC))
    }

    fn get(&self) -> &wgpu::Buffer {
        match self {
            Kept::Growing(b) => b.get(),
            Kept::Fixed(b) => b,
        }
    }
}

const STORAGE_IN: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);

/// A pass's bind group over buffers it keeps between calls: rebuilt only
/// when one of them grows.
pub struct KeptGroup {
    label: &'static str,
    bindings: Vec<(u32, Kept)>,
    group: Option<wgpu::BindGroup>,
}

impl KeptGroup {
    /// A group over `bindings` (binding number, buffer); the bind group
    /// itself is built by the first `update`.
    pub fn new(label: &'static str, bindings: Vec<(u32, Kept)>) -> KeptGroup {
        KeptGroup {
            label,
            bindings,
            group: None,
        }
    }

    /// The kept buffers of an io bind group as `io` declares it.
    pub fn for_io(device: &wgpu::Device, label: &'static str, io: &[crate::gpu::layout::Io]) -> KeptGroup {
        use crate::gpu::layout::Io;
        let bindings = io
            .iter()
            .map(|&b| {
                let kept = match b {
                    Io::In(_, name) => Kept::input(name),
                    Io::Out(_, name) => Kept::output(name),
                    Io::Uniform(_, name, bytes) => Kept::Fixed(zeroed_buffer(
                        device,
                        name,
                        bytes,
                        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    )),
                };
                (b.binding(), kept)
            })
            .collect();
        Self::new(label, bindings)
    }

    fn slot(&mut self, binding: u32) -> &mut Kept {
        let at = self.bindings.iter().position(|(b, _)| *b == binding);
        &mut self.bindings[at.expect("a binding of the group")].1
    }

    /// Writes `data` into a binding (growing a kept buffer first).
    pub fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, binding: u32, data: &[u8]) -> Result<()> {
        let grown = match self.slot(binding) {
            Kept::Growing(b) => b.write(device, queue, data)?,
            Kept::Fixed(b) => {
                queue.write_buffer(b, 0, data);
                false
            }
        };
        if grown {
            self.group = None;
        }
        Ok(())
    }

    /// Makes room for `bytes` in a kept buffer.
    pub fn reserve(&mut self, device: &wgpu::Device, binding: u32, bytes: u64) -> Result<()> {
        if let Kept::Growing(b) = self.slot(binding)
            && b.reserve(device, bytes)?
        {
            self.group = None;
        }
        Ok(())
    }

    /// The buffer of a binding.
    pub fn buffer(&self, binding: u32) -> &wgpu::Buffer {
        let (_, kept) = self
            .bindings
            .iter()
            .find(|(b, _)| *b == binding)
            .expect("a binding of the group");
        kept.get()
    }

    /// Rebuilds the bind group if a buffer grew (call after writing).
    pub fn update(&mut self, device: &wgpu::Device, layout: &wgpu::BindGroupLayout) {
        if self.group.is_none() {
            let buffers: Vec<(u32, &wgpu::Buffer)> = self.bindings.iter().map(|(b, k)| (*b, k.get())).collect();
            self.group = Some(crate::gpu::layout::bind_group(device, self.label, layout, &buffers));
        }
    }

    /// The bind group (after `update`).
    pub fn group(&self) -> &wgpu::BindGroup {
        self.group.as_ref().expect("KeptGroup used before update")
    }
}

/// Copies a buffer's first `len` elements into a new readback buffer and
/// reads them (blocking).
pub fn read_buffer<T: bytemuck::Pod>(
    ctx: &crate::gpu::GpuContext,
    buffer: &wgpu::Buffer,
    len: usize,
) -> Result<Vec<T>> {
    let bytes = (len * std::mem::size_of::<T>()) as u64;
    let readback = zeroed_buffer(
        &ctx.device,
        "readback",
        bytes,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &readback, 0, bytes.next_multiple_of(4));
    ctx.queue.submit([encoder.finish()]);
    read_back(&ctx.device, &readback, len)
}

#[cfg(test)]
mod tests {
    #[test]
    fn oversized_buffers_are_a_device_error_naming_the_data() {
        let e = super::check_size(128 << 20, "kd-tree triangles", 200 << 20).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let m = e.to_string();
        assert!(
            m.contains("kd-tree triangles") && m.contains("200.0 MiB") && m.contains("128.0 MiB"),
            "{m}"
        );
        assert!(super::check_size(128 << 20, "x", 128 << 20).is_ok());
    }
}
