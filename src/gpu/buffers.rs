//! Buffer creation within the device's limits, and blocking readback.

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

/// `bytes` against a per-binding limit `max`.
pub fn check_size(max: u64, what: &str, bytes: u64) -> Result<()> {
    if bytes > max {
        return Err(Error::Device(format!(
            "{what} needs {:.1} MiB in one storage buffer; this device allows {:.1} MiB per binding \
             (use --device cpu, or a smaller input)",
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
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::internal(format!("waiting for the GPU failed: {e}")))?;
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
