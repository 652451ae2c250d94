//! The grab rules that need no measurement: a fixed grab (self-scheduling, pbrt, Mitsuba) and
//! guided self-scheduling (Polychronopoulos & Kuck 1987), max(grab, ⌈R/(k·P)⌉).

use super::ChunkRule;

/// A chunk size that depends on the items left alone, so an executor may take it without a
/// lock: a constant grab with an atomic `fetch_add`, guided with a compare-and-swap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grab {
    /// The smallest chunk (the whole chunk for a fixed grab).
    pub grab: usize,
    /// Guided's k·P; 0 for a fixed grab.
    pub guided_kp: usize,
}

impl Grab {
    /// Always `grab` items.
    pub const fn fixed(grab: usize) -> Self {
        Self { grab, guided_kp: 0 }
    }

    /// Guided over `workers` workers: max(grab, ⌈R/(k·P)⌉).
    pub const fn guided(grab: usize, k: usize, workers: usize) -> Self {
        Self {
            grab,
            guided_kp: k * workers,
        }
    }

    /// The chunk for `remaining` items left (not clamped to them).
    #[inline]
    pub fn size(&self, remaining: usize) -> usize {
        if self.guided_kp == 0 {
            self.grab
        } else {
            self.grab.max(remaining.div_ceil(self.guided_kp))
        }
    }

    /// The chunk whatever is left, for a fixed grab.
    pub fn constant(&self) -> Option<usize> {
        (self.guided_kp == 0).then_some(self.grab)
    }
}

impl ChunkRule for Grab {
    fn next(&mut self, _worker: usize, remaining: usize) -> usize {
        self.size(remaining)
    }

    fn as_grab(&self) -> Option<Grab> {
        Some(*self)
    }
}
