//! Twin of `clustering/sort.wesl`: the shape of the GPU's bitonic sort of (key, light)
//! entries, which z-binning uses: its padded size, and the merges after
//! each block is sorted in a workgroup's memory.

/// Entries one workgroup sorts in its own memory (two per invocation).
pub const SORT_BLOCK: u32 = 512;

/// The key of a light left out of every cluster, and of padding: after every other.
pub const NO_KEY: u32 = u32::MAX;

/// Entries of the sorted order: the light count rounded up to a power of two, at least a
/// sort block.
pub fn sorted_size(lights: u32) -> u32 {
    lights.next_power_of_two().max(SORT_BLOCK)
}

/// The bitonic merges after each block is sorted, in order: `(k, j)` a compare-and-swap
/// step over all entries at distance j within runs of k, or `(k, 0)` the steps of distance
/// below a block, done within each block.
pub fn merge_schedule(n: u32) -> Vec<(u32, u32)> {
    let mut steps = Vec::new();
    let mut k = 2 * SORT_BLOCK;
    while k <= n {
        let mut j = k / 2;
        while j >= SORT_BLOCK {
            steps.push((k, j));
            j /= 2;
        }
        steps.push((k, 0));
        k *= 2;
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The merges double k from two blocks to n, each with its steps from k/2 down to a
    /// block, then the step within blocks.
    #[test]
    fn the_merge_schedule_covers_every_bitonic_step_above_a_block() {
        assert!(merge_schedule(SORT_BLOCK).is_empty());
        assert_eq!(
            merge_schedule(4 * SORT_BLOCK),
            vec![(1024, 512), (1024, 0), (2048, 1024), (2048, 512), (2048, 0)]
        );
        assert_eq!(sorted_size(3), SORT_BLOCK);
        assert_eq!(sorted_size(SORT_BLOCK + 1), 2 * SORT_BLOCK);
    }
}
