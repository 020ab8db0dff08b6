//! Copying GPU buffers and textures back to the CPU.

use super::{Gpu, GpuError};

/// Read `size` bytes at `offset` of `buffer` (which must allow COPY_SRC).
pub fn read_buffer(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<u8>, GpuError> {
    read_back(gpu, size, |encoder, staging| {
        encoder.copy_buffer_to_buffer(buffer, offset, staging, 0, size);
    })
}

/// Read a whole 2D texture as tightly packed rows of `bytes_per_pixel`.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    let (width, height) = (texture.width(), texture.height());
    // Every format read back is uncompressed and colour: one block is one texel.
    let bytes_per_pixel = texture
        .format()
        .block_copy_size(None)
        .ok_or_else(|| GpuError::Captured(format!("{:?} cannot be read back", texture.format())))?;
    let row = width * bytes_per_pixel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let bytes = read_back(gpu, padded as u64 * height as u64, |encoder, staging| {
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(height),
                },
            },
            texture.size(),
        );
    })?;
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&bytes[start..start + row as usize]);
    }
    Ok(out)
}

/// Copy `size` bytes into a mappable staging buffer with `copy`, then map and read them.
fn read_back(
    gpu: &Gpu,
    size: u64,
    copy: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::Buffer),
) -> Result<Vec<u8>, GpuError> {
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    copy(&mut encoder, &staging);
    gpu.queue.submit([encoder.finish()]);
    map_and_copy(gpu, &staging, size as usize)
}

fn map_and_copy(gpu: &Gpu, staging: &wgpu::Buffer, size: usize) -> Result<Vec<u8>, GpuError> {
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Captured(e.to_string()))?
        .map_err(|e| GpuError::Captured(format!("mapping a read-back buffer: {e}")))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Captured(format!("reading a mapped buffer: {e}")))?[..size]
        .to_vec();
    staging.unmap();
    Ok(data)
}
