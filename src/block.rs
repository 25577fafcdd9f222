//! Block membership as cell order: particles of block b occupy the contiguous slots
//! `starts[b]..starts[b + 1]`, rebuilt each step by a stable counting sort (histogram,
//! prefix sum, scatter) that keeps the within-block order of SPEC.md section 4, stage 1.

use std::ops::Range;

/// Which slots belong to which block, and which blocks hold particles.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BlockOrder {
    /// `starts[b]..starts[b + 1]` are the slots of block b; length blocks + 1.
    starts: Vec<u32>,
    /// Indices of the blocks holding at least one particle, ascending.
    occupied: Vec<u32>,
}

impl BlockOrder {
    /// The order of `counts[b]` particles per block, stored block after block.
    pub fn from_counts(counts: &[u32]) -> Self {
        let mut starts = Vec::with_capacity(counts.len() + 1);
        starts.push(0);
        let mut total = 0u32;
        for &count in counts {
            total += count;
            starts.push(total);
        }
        let mut order = Self {
            starts,
            occupied: Vec::new(),
        };
        order.collect_occupied();
        order
    }

    /// Stable counting sort: given the block of each particle in its current slot, sets
    /// the new block ranges and writes to `order` the old slot of each new slot (old slots
    /// ascending within a block).
    pub fn sort(&mut self, block_of_slot: &[u32], block_count: usize, order: &mut Vec<u32>) {
        let starts = &mut self.starts;
        starts.clear();
        starts.resize(block_count + 1, 0);
        for &b in block_of_slot {
            starts[b as usize + 1] += 1;
        }
        for b in 1..=block_count {
            starts[b] += starts[b - 1];
        }
        // Scatter with starts[b] as block b's cursor; afterwards starts[b] is the end of b.
        order.clear();
        order.resize(block_of_slot.len(), 0);
        for (slot, &b) in block_of_slot.iter().enumerate() {
            let cursor = &mut starts[b as usize];
            order[*cursor as usize] = slot as u32;
            *cursor += 1;
        }
        starts.copy_within(0..block_count, 1);
        starts[0] = 0;
        self.collect_occupied();
    }

    fn collect_occupied(&mut self) {
        self.occupied.clear();
        let blocks = self.starts.windows(2).enumerate();
        self.occupied
            .extend(blocks.filter(|(_, w)| w[1] > w[0]).map(|(b, _)| b as u32));
    }

    /// The slots of block `b`.
    pub fn range(&self, b: usize) -> Range<usize> {
        self.starts[b] as usize..self.starts[b + 1] as usize
    }

    /// Number of particles in block `b`.
    pub fn count(&self, b: usize) -> usize {
        self.range(b).len()
    }

    /// Indices of the blocks that hold particles, ascending.
    pub fn occupied(&self) -> &[u32] {
        &self.occupied
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sort_groups_by_block_and_keeps_slot_order_within_a_block() {
        let blocks = [2, 0, 2, 1, 0, 2];
        let mut order = Vec::new();
        let mut bo = BlockOrder::default();
        bo.sort(&blocks, 4, &mut order);
        assert_eq!(order, vec![1, 4, 3, 0, 2, 5]);
        assert_eq!(bo.range(0), 0..2);
        assert_eq!(bo.range(1), 2..3);
        assert_eq!(bo.range(2), 3..6);
        assert_eq!(bo.range(3), 6..6);
        assert_eq!(bo.occupied(), &[0, 1, 2]);
        assert_eq!(bo.count(2), 3);
    }

    #[test]
    fn sort_is_stable_for_many_equal_keys() {
        let blocks: Vec<u32> = (0..1000).map(|i| (i * 7919 % 13) as u32).collect();
        let mut order = Vec::new();
        let mut bo = BlockOrder::default();
        bo.sort(&blocks, 13, &mut order);
        for pair in order.windows(2) {
            let (a, b) = (pair[0] as usize, pair[1] as usize);
            assert!(blocks[a] < blocks[b] || (blocks[a] == blocks[b] && a < b));
        }
    }

    #[test]
    fn resorting_reuses_buffers_and_forgets_old_blocks() {
        let mut order = Vec::new();
        let mut bo = BlockOrder::default();
        bo.sort(&[5, 5, 1], 6, &mut order);
        bo.sort(&[0, 1], 3, &mut order);
        assert_eq!(order, vec![0, 1]);
        assert_eq!(bo.occupied(), &[0, 1]);
        assert_eq!(bo.range(2), 2..2);
    }

    #[test]
    fn from_counts_matches_sort() {
        let mut order = Vec::new();
        let mut sorted = BlockOrder::default();
        sorted.sort(&[3, 0, 3, 3], 5, &mut order);
        assert_eq!(BlockOrder::from_counts(&[1, 0, 0, 3, 0]), sorted);
    }
}
