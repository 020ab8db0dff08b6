//! Whether a device still works after a failure (a buffer written and read back), and its
//! replacement when it does not.

use super::{Gpu, GpuError, read_buffer};

impl Gpu {
    /// Whether the device can still run work: not lost, no work left over from a wait that
    /// ran past its limit, and a small write and read-back comes back intact. A run calls it
    /// after a failure to decide whether to `reopen`.
    pub fn check_health(&self) -> Result<(), GpuError> {
        self.check_lost()?;
        if self.overran.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(GpuError::TimedOut {
                limit: self.cell_timeout(),
            });
        }
        const PROBE: [u8; 16] = *b"clusterlab probe";
        let buffer = self.scoped("device check", || {
            let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("device check"),
                size: PROBE.len() as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            self.queue.write_buffer(&buffer, 0, &PROBE);
            buffer
        })?;
        self.begin_cell();
        let back = self.scoped("device check", || {
            read_buffer(self, &buffer, 0, PROBE.len() as u64)
        })??;
        self.check_lost()?;
        if back != PROBE {
            return Err(GpuError::Captured(
                "device check: a buffer written and read back came back changed".into(),
            ));
        }
        Ok(())
    }

    /// After a failure: keep the device when `check_health` passes, else put a new one in
    /// its place. Returns what was wrong with the old one (None when it was kept), or why no
    /// new one could be opened.
    pub fn renew_if_unusable(&mut self) -> Result<Option<GpuError>, GpuError> {
        let Err(broken) = self.check_health() else {
            return Ok(None);
        };
        *self = self.reopen()?;
        Ok(Some(broken))
    }
}
