//! The failure queue: nodes ordered by their separation eigenvalue `v+`
//! (largest first, ties broken by the smaller node id), lazily invalidated.
//!
//! Updating a node pushes a new entry and bumps the node's stamp; entries
//! whose stamp is stale are skipped when popped. No float-keyed map is used:
//! the order is a total order on (`v+` by `f64::total_cmp`, node id).

use crate::math::GrowGently;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

#[derive(Clone, Copy, Debug)]
struct Entry {
    value: f64,
    node: u32,
    stamp: u32,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Larger value first; on ties the smaller node id first; then newer stamp.
    fn cmp(&self, o: &Self) -> Ordering {
        self.value
            .total_cmp(&o.value)
            .then_with(|| o.node.cmp(&self.node))
            .then_with(|| self.stamp.cmp(&o.stamp))
    }
}

/// A max-queue of node failure values with lazy invalidation.
#[derive(Clone, Debug, Default)]
pub struct FailureQueue {
    heap: BinaryHeap<Entry>,
    stamps: Vec<u32>,
}

impl FailureQueue {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Set node `node`'s value (replacing any earlier one). Non-finite values
    /// and values not above `threshold` are not queued (but still invalidate
    /// the node's earlier entry).
    pub fn set(&mut self, node: u32, value: f64, threshold: f64) {
        let i = node as usize;
        if self.stamps.len() <= i {
            self.stamps.resize_gently(i + 1, 0);
        }
        self.stamps[i] = self.stamps[i].wrapping_add(1);
        if value.is_finite() && value > threshold {
            self.heap.push(Entry {
                value,
                node,
                stamp: self.stamps[i],
            });
        }
    }

    /// Remove node `node` from the queue.
    pub fn remove(&mut self, node: u32) {
        self.set(node, f64::NAN, 0.0);
    }

    /// The node with the largest current value and that value, removed.
    pub fn pop(&mut self) -> Option<(u32, f64)> {
        while let Some(e) = self.heap.pop() {
            if self.stamps.get(e.node as usize) == Some(&e.stamp) {
                // Consumed: a later `set` is needed to queue the node again.
                self.stamps[e.node as usize] = e.stamp.wrapping_add(1);
                return Some((e.node, e.value));
            }
        }
        None
    }

    /// The current top without removing it.
    pub fn peek(&mut self) -> Option<(u32, f64)> {
        while let Some(e) = self.heap.peek() {
            if self.stamps.get(e.node as usize) == Some(&e.stamp) {
                return Some((e.node, e.value));
            }
            self.heap.pop();
        }
        None
    }

    /// Number of heap entries, stale ones included (for memory accounting).
    pub fn raw_len(&self) -> usize {
        self.heap.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_ties_and_invalidation() {
        let mut q = FailureQueue::new();
        q.set(5, 2.0, 1.0);
        q.set(3, 2.0, 1.0);
        q.set(7, 3.0, 1.0);
        q.set(9, 0.5, 1.0); // below threshold: not queued
        q.set(5, 4.0, 1.0); // replaces 5's entry
        assert_eq!(q.peek(), Some((5, 4.0)));
        assert_eq!(q.pop(), Some((5, 4.0)));
        assert_eq!(q.pop(), Some((7, 3.0)));
        q.remove(3);
        assert_eq!(
            q.pop(),
            None,
            "node 3 was removed, node 5's old entry is stale"
        );
        q.set(3, 1.5, 1.0);
        q.set(2, 1.5, 1.0);
        assert_eq!(q.pop(), Some((2, 1.5)), "ties go to the smaller node id");
        assert_eq!(q.pop(), Some((3, 1.5)));
        q.set(4, f64::NAN, 0.0);
        q.set(4, f64::INFINITY, 0.0);
        assert_eq!(q.pop(), None, "non-finite values are never queued");
    }

    #[test]
    fn deterministic_regardless_of_insertion_order() {
        let vals: Vec<(u32, f64)> = (0..100).map(|i| (i, ((i * 37) % 11) as f64)).collect();
        let drain = |order: &mut dyn Iterator<Item = &(u32, f64)>| {
            let mut q = FailureQueue::new();
            for &(n, v) in order {
                q.set(n, v, -1.0);
            }
            std::iter::from_fn(|| q.pop()).collect::<Vec<_>>()
        };
        assert_eq!(drain(&mut vals.iter()), drain(&mut vals.iter().rev()));
    }
}
