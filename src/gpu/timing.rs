//! Per-pass GPU time from timestamp queries, or wall-clock per pass where the adapter has
//! none (each pass then runs in its own submission and is waited for).

use super::{Gpu, GpuError, read_buffer};

/// Time of each pass of one frame, in the order the passes ran.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    pub passes: Vec<(String, f64)>,
    /// True when the times are GPU timestamps, false when wall-clock.
    pub gpu_timestamps: bool,
}

impl Timings {
    pub fn total_ms(&self) -> f64 {
        self.passes.iter().fold(0.0, |total, (_, ms)| total + ms)
    }

    /// Time of a pass by name (0 when it did not run); passes that ran twice add up.
    pub fn get(&self, name: &str) -> f64 {
        self.passes
            .iter()
            .filter(|(n, _)| n == name)
            // A fold from +0.0: an empty float sum is -0.0 in Rust.
            .fold(0.0, |total, (_, ms)| total + ms)
    }
}

/// Where a pass writes its timestamps (when the adapter has them).
#[derive(Clone, Copy)]
pub struct TimestampSlot<'a> {
    query_set: &'a wgpu::QuerySet,
    index: u32,
}

impl<'a> TimestampSlot<'a> {
    pub fn render(slot: Option<Self>) -> Option<wgpu::RenderPassTimestampWrites<'a>> {
        slot.map(|s| wgpu::RenderPassTimestampWrites {
            query_set: s.query_set,
            beginning_of_pass_write_index: Some(s.index * 2),
            end_of_pass_write_index: Some(s.index * 2 + 1),
        })
    }
    pub fn compute(slot: Option<Self>) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        slot.map(|s| wgpu::ComputePassTimestampWrites {
            query_set: s.query_set,
            beginning_of_pass_write_index: Some(s.index * 2),
            end_of_pass_write_index: Some(s.index * 2 + 1),
        })
    }

    /// The beginning (`end` false) or the end of a pass that runs as two compute passes.
    pub fn compute_part(
        slot: Option<Self>,
        end: bool,
    ) -> Option<wgpu::ComputePassTimestampWrites<'a>> {
        slot.map(|s| wgpu::ComputePassTimestampWrites {
            query_set: s.query_set,
            beginning_of_pass_write_index: (!end).then_some(s.index * 2),
            end_of_pass_write_index: end.then_some(s.index * 2 + 1),
        })
    }
}

/// Hands out timestamp slots to passes and turns them into milliseconds.
pub struct PassTimer {
    query_set: Option<wgpu::QuerySet>,
    capacity: u32,
    names: Vec<String>,
    wall: Vec<f64>,
}

impl PassTimer {
    pub fn new(gpu: &Gpu, max_passes: u32) -> Self {
        let query_set = gpu.timestamps.then(|| {
            gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: max_passes * 2,
            })
        });
        Self {
            query_set,
            capacity: max_passes,
            names: Vec::new(),
            wall: Vec::new(),
        }
    }

    /// A timestamp slot for the next pass named `name` (None without timestamps or when
    /// full).
    pub fn claim_slot(&mut self, name: &str) -> Option<TimestampSlot<'_>> {
        let index = self.claim(name)?;
        self.query_set
            .as_ref()
            .map(|query_set| TimestampSlot { query_set, index })
    }

    fn claim(&mut self, name: &str) -> Option<u32> {
        self.query_set.as_ref()?;
        let index = self.names.len() as u32;
        if index >= self.capacity {
            return None;
        }
        self.names.push(name.to_string());
        Some(index)
    }

    /// Whether passes must be timed by the wall clock (no timestamp queries).
    pub fn wall_clock(&self) -> bool {
        self.query_set.is_none()
    }

    /// Record a wall-clock pass time (used when there are no timestamps).
    pub fn record_wall(&mut self, name: &str, ms: f64) {
        self.names.push(name.to_string());
        self.wall.push(ms);
    }

    /// Resolve the queries of the work submitted so far and return the timings.
    pub fn finish(self, gpu: &Gpu) -> Result<Timings, GpuError> {
        let Some(query_set) = &self.query_set else {
            return Ok(Timings {
                passes: self.names.into_iter().zip(self.wall).collect(),
                gpu_timestamps: false,
            });
        };
        let count = self.names.len() as u32 * 2;
        if count == 0 {
            return Ok(Timings::default());
        }
        let size = count as u64 * 8;
        let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        encoder.resolve_query_set(query_set, 0..count, &resolve, 0);
        gpu.queue.submit([encoder.finish()]);
        let bytes = read_buffer(gpu, &resolve, 0, size)?;
        let ticks: &[u64] = bytemuck::cast_slice(&bytes);
        let period_ms = gpu.queue.get_timestamp_period() as f64 / 1e6;
        let passes = self
            .names
            .into_iter()
            .enumerate()
            .map(|(i, name)| {
                let (a, b) = (ticks[2 * i], ticks[2 * i + 1]);
                (name, b.saturating_sub(a) as f64 * period_ms)
            })
            .collect();
        Ok(Timings {
            passes,
            gpu_timestamps: true,
        })
    }
}
