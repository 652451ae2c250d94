//! The order a worker runs the items of one hand-out in: scanline order (frame, then row, then
//! column of their top-left corners) rather than the hand-out order. In `scatter` order, the
//! default of `guided` and the factoring family, consecutive items lie far apart and each ray
//! misses the caches its predecessor warmed. The image does not change: a pixel is a pure
//! function of the scene, the tracer and its seed.
//!
//! What running them so saves is M-119. The order has to be cheap beside 1–2 µs pixels, so
//! each worker ranks its own hand-out's items on their grid and walks a bitmap of the ranks:
//! linear in the hand-out plus one word per 64 cells of the span it covers.

use crate::core::render::{Region, WorkItem};
use std::ops::Range;

/// Hand-outs of fewer items run as handed out: too few to share caches.
pub(super) const SORT_FROM: usize = 4;

/// Nor do hand-outs of less than 1/`SPARSE` of the items: they lie too far apart to share
/// caches, and the bitmap walk costs one word per 64 cells of the span they cover, up to
/// `SPARSE`/64 = 4 words per item of such a hand-out.
pub(super) const SPARSE: usize = 256;

/// The indices `range` into `order` as handed out.
pub(super) fn as_handed_out(range: Range<usize>, order: &mut Vec<u32>) {
    order.clear();
    order.extend(range.map(|i| i as u32));
}

/// A worker's reusable buffers for ordering its hand-outs.
#[derive(Default)]
pub(super) struct ScanlineScratch {
    ranks: Vec<u64>,
    marks: Vec<u64>,
    slot: Vec<u32>,
}

impl ScanlineScratch {
    /// The indices `range` of `items` (one hand-out) into `order`: as handed out where they
    /// are fewer than [`SORT_FROM`] or less than 1/[`SPARSE`] of all, or not rectangles on one
    /// grid; else in scanline order. The grid is the hand-out's own (its largest item's size),
    /// which ranks the cells of any grid [`super::decompose`] cuts in scanline order.
    pub(super) fn order(&mut self, items: &[WorkItem], range: Range<usize>, order: &mut Vec<u32>) {
        order.clear();
        if !self.sort_into(items, range.clone(), order) {
            as_handed_out(range, order);
        }
    }

    /// [`Self::order`]'s scanline order into `order` (empty on entry); false, `order` left
    /// empty, where the hand-out runs as handed out.
    fn sort_into(&mut self, items: &[WorkItem], range: Range<usize>, order: &mut Vec<u32>) -> bool {
        let start = range.start;
        let chunk = &items[range.clone()];
        let ranked = if chunk.len() < SORT_FROM || chunk.len() * SPARSE < items.len() {
            None
        } else {
            self.rank(chunk)
        };
        // Not on a grid, or already in scanline order (a scanline decomposition).
        let Some(Ranked {
            lo,
            hi,
            sorted: false,
        }) = ranked
        else {
            return false;
        };
        let span = (hi - lo) as usize + 1;
        // A hand-out of clipped edge items alone can rank far apart: keep the walk bounded.
        if span > 4 * items.len() + 64 {
            return false;
        }
        self.marks.clear();
        self.marks.resize(span.div_ceil(64), 0);
        if self.slot.len() < span {
            self.slot.resize(span, 0);
        }
        for (k, &r) in self.ranks.iter().enumerate() {
            let r = (r - lo) as usize;
            let bit = 1u64 << (r % 64);
            if self.marks[r / 64] & bit != 0 {
                // Two items on one cell: not one grid.
                return false;
            }
            self.marks[r / 64] |= bit;
            self.slot[r] = (start + k) as u32;
        }
        for (w, &word) in self.marks.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                order.push(self.slot[w * 64 + bits.trailing_zeros() as usize]);
                bits &= bits - 1;
            }
        }
        true
    }

    /// Each item's cell index on the hand-out's grid into `self.ranks`: (frame · rows + y / ch)
    /// · columns + x / cw, with cw × ch the largest item's size (shifts where it is a power of
    /// two: the divisions were most of the ~8 ns per item this order added to zero-work
    /// hand-outs). `None` where an item is not a rectangle on that grid.
    fn rank(&mut self, chunk: &[WorkItem]) -> Option<Ranked> {
        let (mut cw, mut ch, mut right, mut bottom) = (1u32, 1u32, 0u32, 0u32);
        for it in chunk {
            let Region::Rect { x, y, w, h } = it.region else {
                return None;
            };
            (cw, ch) = (cw.max(w), ch.max(h));
            right = right.max(x.saturating_add(w));
            bottom = bottom.max(y.saturating_add(h));
        }
        let (columns, rows) = (right.div_ceil(cw) as u64, bottom.div_ceil(ch) as u64);
        let (col, row) = (Cells::of(cw), Cells::of(ch));
        self.ranks.clear();
        let mut out = Ranked {
            lo: u64::MAX,
            hi: 0,
            sorted: true,
        };
        for it in chunk {
            let Region::Rect { x, y, .. } = it.region else {
                return None;
            };
            let r = (it.frame as u64 * rows + row.index(y)?) * columns + col.index(x)?;
            out.sorted &= self.ranks.last().is_none_or(|&p| p < r);
            (out.lo, out.hi) = (out.lo.min(r), out.hi.max(r));
            self.ranks.push(r);
        }
        Some(out)
    }
}

/// What [`ScanlineScratch::rank`] found of a hand-out.
struct Ranked {
    lo: u64,
    hi: u64,
    /// Its ranks rise item by item: it is in scanline order already.
    sorted: bool,
}

/// Cell index along one axis of a grid of cells `c` pixels wide.
#[derive(Clone, Copy)]
enum Cells {
    /// A power of two: a shift.
    Shift(u32),
    Div(u32),
}

impl Cells {
    fn of(c: u32) -> Self {
        if c.is_power_of_two() {
            Self::Shift(c.trailing_zeros())
        } else {
            Self::Div(c)
        }
    }

    /// The cell of pixel coordinate `v`, `None` off the cells' edges.
    #[inline(always)]
    fn index(self, v: u32) -> Option<u64> {
        match self {
            Self::Shift(s) => (v & ((1 << s) - 1) == 0).then_some((v >> s) as u64),
            Self::Div(c) => v.is_multiple_of(c).then_some((v / c) as u64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::{decompose, decompose_frames, Chunk, Order};

    fn top_left(it: &WorkItem) -> (u32, u32, u32) {
        match it.region {
            Region::Rect { x, y, .. } => (it.frame, y, x),
            Region::Pixels(_) => unreachable!(),
        }
    }

    /// A hand-out of scattered items (pixels, tiles with clipped edges, two frames) runs
    /// frame by frame, top row first, left to right, each item once.
    #[test]
    fn a_hand_out_runs_in_scanline_order() {
        for items in [
            decompose(8, 8, Chunk::Tile { w: 1, h: 1 }, Order::Scatter),
            decompose(100, 70, Chunk::Tile { w: 16, h: 16 }, Order::Scatter),
            decompose_frames(13, 9, 2, Chunk::Tile { w: 2, h: 3 }, Order::Hilbert),
        ] {
            let mut scratch = ScanlineScratch::default();
            let mut order = Vec::new();
            let n = items.len();
            for range in [n / 4..n * 3 / 4, 0..n, 1..2, n - 1..n, n - 5..n] {
                scratch.order(&items, range.clone(), &mut order);
                let ran: Vec<_> = order
                    .iter()
                    .map(|&i| top_left(&items[i as usize]))
                    .collect();
                let mut sorted = ran.clone();
                sorted.sort();
                assert_eq!(ran, sorted);
                let mut seen = order.clone();
                seen.sort();
                let want: Vec<u32> = range.map(|i| i as u32).collect();
                assert_eq!(seen, want, "every item of the hand-out once");
            }
            // The hand-out order itself is not scanline (else this would prove nothing).
            scratch.order(&items, 0..n, &mut order);
            assert_ne!(order, (0..n as u32).collect::<Vec<_>>());
        }
    }

    /// Hand-outs of fewer than [`SORT_FROM`] items, or of less than 1/[`SPARSE`] of the
    /// items, run as handed out.
    #[test]
    fn short_and_sparse_hand_outs_run_as_handed_out() {
        let items = decompose(64, 64, Chunk::Tile { w: 1, h: 1 }, Order::Scatter);
        let mut scratch = ScanlineScratch::default();
        let mut order = Vec::new();
        let sparse = items.len() / SPARSE;
        for (range, sorted) in [
            (100..100 + SORT_FROM - 1, false),
            (100..100 + sparse - 1, false),
            (100..100 + sparse, true),
        ] {
            scratch.order(&items, range.clone(), &mut order);
            let as_handed: Vec<u32> = range.map(|i| i as u32).collect();
            assert_eq!(order == as_handed, !sorted, "{order:?}");
        }
    }

    /// Hand-outs whose items are not rectangles on one grid (a pixel list, an item off the
    /// grid, two items on one cell) run as handed out, each item once.
    #[test]
    fn hand_outs_off_a_grid_run_as_handed_out() {
        let grid = decompose(8, 8, Chunk::Tile { w: 2, h: 2 }, Order::Scatter);
        let mut scratch = ScanlineScratch::default();
        let mut order = Vec::new();
        scratch.order(&grid, 0..16, &mut order);
        assert_ne!(order, (0..16).collect::<Vec<u32>>(), "a grid is sorted");
        let mut twice = grid.clone();
        twice[3] = twice[0].clone();
        let mut off = grid.clone();
        off[1] = WorkItem::rect(1, 1, 0, 2, 2);
        let mut list = grid;
        list[0].region = Region::Pixels(vec![0, 1]);
        for items in [twice, off, list] {
            scratch.order(&items, 0..16, &mut order);
            assert_eq!(order, (0..16).collect::<Vec<u32>>());
        }
        // The scratch is still good for a grid after a refusal.
        let grid = decompose(8, 8, Chunk::Tile { w: 2, h: 2 }, Order::Scatter);
        let mut again = Vec::new();
        scratch.order(&grid, 0..16, &mut again);
        let mut ran: Vec<_> = again.iter().map(|&i| top_left(&grid[i as usize])).collect();
        let sorted = ran.clone();
        ran.sort();
        assert_eq!(ran, sorted);
    }
}
