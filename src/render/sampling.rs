//! What a sampled light loop or sampled shadows bind (`common/sampling.wesl`,
//! `shading/light_loop/`, `shading/shadows/`): the frame's seed, and with temporal reuse
//! each pixel's reservoir of this frame and the last.

use super::reflect::BufferSizes;
use crate::gpu::Gpu;
use crate::render::bindings::Binding;

/// The uniform `sample_frame`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct SampleFrame {
    seed: u32,
    history: u32,
    _pad: [u32; 2],
}

/// The seed of a frame at `time` s for a variant seeded `seed` (SplitMix64's finaliser over
/// both): frames of a sequence differ, and a frame drawn again draws the same numbers, so a
/// fresh renderer draws what a sequence's renderer drew at the same time.
pub fn frame_seed(seed: u32, time: f64) -> u32 {
    let mut z = (u64::from(seed) << 32 ^ time.to_bits()).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    (z ^ (z >> 31)) as u32
}

/// The buffers of a sampled variant's frames.
pub struct SampleBuffers {
    frame: wgpu::Buffer,
    /// Temporal reuse: this frame's reservoirs and the last frame's.
    reservoirs: Option<[wgpu::Buffer; 2]>,
    /// Bytes a pixel keeps across frames (its two reservoirs).
    kept_per_pixel: u32,
    seed: u32,
    /// The frame's values as last written.
    written: SampleFrame,
}

impl SampleBuffers {
    /// The buffers at the sizes the light loop declares (`restir_temporal.wesl`), for a
    /// variant seeded `seed` whose loop reuses earlier frames' reservoirs or not.
    pub fn new(
        gpu: &Gpu,
        sizes: &BufferSizes,
        (seed, reuses_frames): (u32, bool),
        pixels: u64,
        time: f64,
    ) -> Self {
        let frame = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sample frame"),
            size: std::mem::size_of::<SampleFrame>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Both hold `StoredReservoir`s; an instrumented pass declares only the previous.
        let reservoir_bytes = sizes.bindable(Binding::PreviousReservoirs, pixels);
        let reservoir = |label| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: reservoir_bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let reservoirs =
            reuses_frames.then(|| [reservoir("reservoirs"), reservoir("previous reservoirs")]);
        let kept_per_pixel = match &reservoirs {
            Some(_) => 2 * sizes.bindable(Binding::PreviousReservoirs, 1) as u32,
            None => 0,
        };
        let mut out = Self {
            frame,
            reservoirs,
            kept_per_pixel,
            seed,
            written: SampleFrame::default(),
        };
        out.set_frame(gpu, time, false);
        out
    }

    /// Make the next frame the one at `time` s, `history` saying whether the last frame's
    /// reservoirs are its history (a frame that follows it).
    pub fn set_frame(&mut self, gpu: &Gpu, time: f64, history: bool) {
        let frame = SampleFrame {
            seed: frame_seed(self.seed, time),
            history: u32::from(history && self.reservoirs.is_some()),
            _pad: [0; 2],
        };
        if frame != self.written {
            gpu.queue
                .write_buffer(&self.frame, 0, bytemuck::bytes_of(&frame));
            self.written = frame;
        }
    }

    /// Seed the random numbers with `seed` instead of the variant's (independent runs of
    /// one frame); takes effect at the next `set_frame`.
    pub fn reseed(&mut self, seed: u32) {
        self.seed = seed;
    }

    /// Before a frame: the last frame's reservoirs become the previous ones, and this frame's
    /// start empty (a background pixel holds none).
    pub fn start_frame(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some([current, previous]) = &self.reservoirs {
            encoder.copy_buffer_to_buffer(current, 0, previous, 0, current.size());
            encoder.clear_buffer(current, 0, None);
        }
    }

    /// What fills the binding declared as `name`, if it is one of these.
    pub fn binding(&self, name: Binding) -> Option<wgpu::BindingResource<'_>> {
        match name {
            Binding::SampleFrame => Some(self.frame.as_entire_binding()),
            Binding::Reservoirs => self.reservoirs.as_ref().map(|r| r[0].as_entire_binding()),
            Binding::PreviousReservoirs => {
                self.reservoirs.as_ref().map(|r| r[1].as_entire_binding())
            }
            _ => None,
        }
    }

    /// Bytes a pixel keeps across frames.
    pub fn bytes_per_pixel(&self) -> u32 {
        self.kept_per_pixel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_and_seeds_draw_different_numbers_and_a_frame_drawn_again_the_same() {
        assert_eq!(frame_seed(1, 0.5), frame_seed(1, 0.5));
        assert_ne!(frame_seed(1, 0.5), frame_seed(2, 0.5));
        assert_ne!(frame_seed(1, 0.5), frame_seed(1, 0.5 + 1.0 / 30.0));
    }
}
