//! A bounded work queue that flushes when full (MoonRay §4: "queues that call their handler when
//! they fill up").
//!
//! Its storage is allocated once, up front, and never grows: [`Queue::push`] checks that the entry
//! fits the storage (a logic error otherwise, never a reallocation), so no heap allocation happens
//! while rendering. The *capacity* is the flush threshold; the storage may be larger than it, by the
//! most entries one handler can add before the driver looks at the queue again (see
//! [`super::queues`]).
//!
//! Two ways to flush: [`Queue::push_or_flush`] calls its handler as soon as the queue holds
//! `capacity` entries (used where the handler is a leaf that needs no other queue: the radiance
//! queue), and [`Queue::push`] reports fullness so that the driver's loop flushes it ("flush
//! whichever queue is full"): a handler that needs the whole worker (the ray, shade and occlusion
//! handlers) cannot be called from inside a method of one of the worker's own queues in safe Rust,
//! and the loop bounds the depth that MoonRay's handler-inside-push recursion leaves unbounded.

/// A queue of `T` with a fixed flush threshold and fixed storage.
#[derive(Debug)]
pub struct Queue<T> {
    items: Vec<T>,
    capacity: usize,
}

impl<T: Copy> Queue<T> {
    /// A queue that is full at `capacity` entries and can hold up to `storage` (at least
    /// `capacity`, at least 1) before it must be flushed.
    pub fn new(capacity: usize, storage: usize) -> Self {
        let capacity = capacity.max(1);
        Queue { items: Vec::with_capacity(storage.max(capacity)), capacity }
    }

    /// Appends `entry`; true when the queue is now full (holds at least its capacity).
    ///
    /// # Panics
    /// When the storage is exhausted: the driver flushes every queue before that can happen, so
    /// this is a bug, never bad input (a `Vec` would reallocate here instead).
    #[inline]
    pub fn push(&mut self, entry: T) -> bool {
        assert!(self.items.len() < self.items.capacity(), "queue storage exhausted (a driver bug)");
        self.items.push(entry);
        self.items.len() >= self.capacity
    }

    /// Appends `entry`; when that fills the queue, calls `handler` on all its entries and empties it.
    #[inline]
    pub fn push_or_flush(&mut self, entry: T, handler: impl FnOnce(&mut [T])) {
        if self.push(entry) {
            self.flush(handler);
        }
    }

    /// Calls `handler` on the entries (if any) and empties the queue.
    pub fn flush(&mut self, handler: impl FnOnce(&mut [T])) {
        if !self.items.is_empty() {
            handler(&mut self.items);
            self.items.clear();
        }
    }

    /// Moves up to `max` entries (the most recently pushed) into `batch`, which is cleared first and
    /// must have the room (its capacity is not grown).
    pub fn take_into(&mut self, batch: &mut Vec<T>, max: usize) {
        let n = self.items.len().min(max);
        assert!(n <= batch.capacity(), "batch storage too small (a driver bug)");
        batch.clear();
        batch.extend_from_slice(&self.items[self.items.len() - n..]);
        self.items.truncate(self.items.len() - n);
    }

    /// Entries waiting.
    #[inline]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// No entry waits.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Holds at least its capacity.
    #[inline]
    pub fn is_full(&self) -> bool {
        self.items.len() >= self.capacity
    }

    /// The flush threshold.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Entries the storage holds (fixed at set-up).
    pub fn storage(&self) -> usize {
        self.items.capacity()
    }

    /// The waiting entries, oldest first.
    pub fn as_slice(&self) -> &[T] {
        &self.items
    }

    /// Drops every waiting entry.
    pub fn clear(&mut self) {
        self.items.clear();
    }
}

/// How many batches of each size a handler saw: bucket `b` counts batches of `2^(b-1) + 1 ..= 2^b`
/// entries (bucket 0: one entry), for `--stats`-style reports of how full the queues ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchHistogram {
    /// Batch counts per power-of-two bucket.
    pub buckets: [u64; 16],
    /// Entries over all batches.
    pub entries: u64,
}

impl BatchHistogram {
    /// Records one batch of `len` entries (nothing for an empty one).
    pub fn record(&mut self, len: usize) {
        if len == 0 {
            return;
        }
        let bucket = (usize::BITS - (len - 1).leading_zeros()) as usize;
        self.buckets[bucket.min(self.buckets.len() - 1)] += 1;
        self.entries += len as u64;
    }

    /// Batches recorded.
    pub fn batches(&self) -> u64 {
        self.buckets.iter().sum()
    }

    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &BatchHistogram) {
        for (a, b) in self.buckets.iter_mut().zip(&other.buckets) {
            *a += b;
        }
        self.entries += other.entries;
    }
}

impl std::fmt::Display for BatchHistogram {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let batches = self.batches();
        write!(f, "{batches} batches, mean {:.1}:", self.entries as f64 / batches.max(1) as f64)?;
        for (b, &n) in self.buckets.iter().enumerate().filter(|(_, &n)| n > 0) {
            write!(f, " ≤{}: {n}", 1usize << b)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_reports_full_exactly_at_capacity() {
        let mut q = Queue::new(4, 6);
        assert_eq!((q.capacity(), q.storage()), (4, 6));
        assert!(!q.push(1) && !q.push(2) && !q.push(3));
        assert!(!q.is_full());
        assert!(q.push(4), "the fourth entry fills a queue of capacity 4");
        assert!(q.is_full() && q.push(5), "past capacity (into the spare storage) it stays full");
        assert_eq!(q.as_slice(), &[1, 2, 3, 4, 5]);
    }

    #[test]
    fn push_or_flush_hands_every_entry_to_the_handler_once_at_capacity() {
        let mut q = Queue::new(8, 8);
        let mut seen = Vec::new();
        let mut flushes = Vec::new();
        for x in 0..100u32 {
            q.push_or_flush(x, |batch| {
                flushes.push(batch.len());
                seen.extend_from_slice(batch);
            });
            // A flush happens exactly when the eighth entry arrives, and leaves the queue empty.
            assert_eq!(q.len(), (x as usize + 1) % 8);
        }
        assert_eq!(flushes, vec![8; 12]);
        q.flush(|batch| {
            flushes.push(batch.len());
            seen.extend_from_slice(batch);
        });
        assert_eq!(flushes.last(), Some(&4), "the drain hands over the rest");
        assert!(q.is_empty());
        assert_eq!(seen, (0..100).collect::<Vec<_>>(), "every entry once, in order");
        let calls = flushes.len();
        q.flush(|_| panic!("an empty queue has nothing to flush"));
        assert_eq!(flushes.len(), calls);
    }

    #[test]
    fn storage_never_grows() {
        let mut q = Queue::new(3, 5);
        let mut batch = Vec::with_capacity(3);
        let mut seen = Vec::new();
        for round in 0..50u32 {
            for k in 0..5 {
                q.push(round * 5 + k);
            }
            while !q.is_empty() {
                q.take_into(&mut batch, 3);
                assert!(batch.len() <= 3 && !batch.is_empty());
                seen.extend_from_slice(&batch);
            }
            assert_eq!((q.storage(), batch.capacity()), (5, 3), "no reallocation");
        }
        seen.sort_unstable();
        assert_eq!(seen, (0..250).collect::<Vec<_>>(), "take_into hands over every entry once");
    }

    #[test]
    #[should_panic(expected = "queue storage exhausted")]
    fn overfilling_the_storage_is_caught_not_reallocated() {
        let mut q = Queue::new(2, 3);
        for x in 0..4 {
            q.push(x);
        }
    }

    #[test]
    fn histogram_buckets_are_powers_of_two() {
        let mut h = BatchHistogram::default();
        for len in [0, 1, 2, 3, 4, 5, 8, 9, 1000, 1 << 20] {
            h.record(len);
        }
        assert_eq!(h.batches(), 9);
        assert_eq!(&h.buckets[..5], &[1, 1, 2, 2, 1]);
        assert_eq!(h.buckets[10], 1);
        assert_eq!(h.buckets[15], 1, "huge batches land in the last bucket");
        assert_eq!(h.entries, (1 + 2 + 3 + 4 + 5 + 8 + 9 + 1000 + (1 << 20)) as u64);
    }
}
