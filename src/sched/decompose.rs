//! Cutting an image into work items by granularity ([`Chunk`]) and hand-out order ([`Order`]).
//!
//! Items are axis-aligned rectangles on a grid of cells (tiles, row bands or the frame); the
//! order sorts the grid cells by scanline, Morton (Z), Hilbert or stratified ([`scatter`])
//! index, stratifies blocks of at least [`BLOCK_PX`]² pixels, or walks the cells in a spiral.
//! Ids are 0..n in hand-out order and every pixel lies in exactly one item.
//!
//! An animation is cut frame by frame ([`decompose_frames`]): all items of frame 0 in the
//! order's sequence, then those of frame 1, … With chunk `frame` one item is one whole frame,
//! the coarsest item there is.

use super::param::{Chunk, Order};
use crate::core::render::WorkItem;

/// The side in pixels of the smallest block `scatter_blocks` keeps together: a run of 16
/// one-pixel items then shares its caches the way a 4² tile does (over single pixels `scatter`
/// cost 1.02–1.05× scanline order on one worker, over 4² tiles 1.00–1.02×; 2-core Xeon VM).
pub const BLOCK_PX: u32 = 4;

/// Items covering a `width`×`height` image, ids 0..n in hand-out order.
pub fn decompose(width: u32, height: u32, chunk: Chunk, order: Order) -> Vec<WorkItem> {
    if width == 0 || height == 0 {
        return Vec::new();
    }
    let (cw, ch) = match chunk {
        Chunk::Tile { w, h } => (w.clamp(1, width), h.clamp(1, height)),
        Chunk::Rows(n) => (width, n.clamp(1, height)),
        Chunk::Frame => (width, height),
    };
    let (gx, gy) = (width.div_ceil(cw), height.div_ceil(ch));
    let cells = cells_in_order(gx, gy, (cw, ch), order);
    cells
        .into_iter()
        .enumerate()
        .map(|(id, (cx, cy))| {
            let (x, y) = (cx * cw, cy * ch);
            WorkItem::rect(id as u32, x, y, cw.min(width - x), ch.min(height - y))
        })
        .collect()
}

/// The cells of a `gx`×`gy` grid of `cw`×`ch` cells in `order`.
fn cells_in_order(gx: u32, gy: u32, (cw, ch): (u32, u32), order: Order) -> Vec<(u32, u32)> {
    match order {
        Order::Scanline => scanline_cells(gx, gy),
        Order::Spiral => spiral(gx, gy),
        Order::Morton => walk_or_sort(gx, gy, |_, code| unmorton(code), |_, x, y| morton(x, y)),
        Order::Hilbert => walk_or_sort(gx, gy, unhilbert, hilbert),
        Order::Scatter => walk_or_sort(gx, gy, unscatter, scatter),
        Order::ScatterBlocks => {
            // The blocks in `scatter` order, the cells of each in scanline order: the order of
            // the key (scatter(block), y % bh, x % bw).
            let (bw, bh) = (BLOCK_PX.div_ceil(cw), BLOCK_PX.div_ceil(ch));
            let blocks = walk_or_sort(gx.div_ceil(bw), gy.div_ceil(bh), unscatter, scatter);
            let mut cells = Vec::with_capacity(gx as usize * gy as usize);
            for (bx, by) in blocks {
                for y in by * bh..((by + 1) * bh).min(gy) {
                    cells.extend((bx * bw..((bx + 1) * bw).min(gx)).map(|x| (x, y)));
                }
            }
            cells
        }
    }
}

fn scanline_cells(gx: u32, gy: u32) -> Vec<(u32, u32)> {
    (0..gy).flat_map(|y| (0..gx).map(move |x| (x, y))).collect()
}

/// The cells of a `gx`×`gy` grid by increasing `key(side, x, y)`, where `decode(side, k)`
/// inverts it on the `side`×`side` square, side the power of two that holds the grid: the
/// square's keys walked in order, cells outside the grid skipped, where the square holds at
/// most four keys per cell; else the grid sorted by key ([`sort_cells`]). The walk is linear
/// (M-122).
fn walk_or_sort<K: Ord>(
    gx: u32,
    gy: u32,
    decode: impl Fn(u32, u64) -> (u32, u32),
    key: impl Fn(u32, u32, u32) -> K,
) -> Vec<(u32, u32)> {
    let side = gx.max(gy).next_power_of_two();
    let (keys, n) = (side as u64 * side as u64, gx as u64 * gy as u64);
    if keys > 4 * n {
        let mut cells = scanline_cells(gx, gy);
        sort_cells(&mut cells, |x, y| key(side, x, y));
        return cells;
    }
    let mut cells = Vec::with_capacity(n as usize);
    cells.extend(
        (0..keys)
            .map(|k| decode(side, k))
            .filter(|&(x, y)| x < gx && y < gy),
    );
    cells
}

/// Sort scanline-ordered `cells` by `key`, each key computed once (M-123). Ties keep scanline
/// order (the keys above are distinct anyway), so this is the stable sort by `key`.
fn sort_cells<K: Ord>(cells: &mut Vec<(u32, u32)>, key: impl Fn(u32, u32) -> K) {
    let mut keyed: Vec<(K, u32, u32)> = cells.iter().map(|&(x, y)| (key(x, y), y, x)).collect();
    keyed.sort_unstable();
    cells.clear();
    cells.extend(keyed.into_iter().map(|(_, y, x)| (x, y)));
}

/// Items covering every pixel of `frames` frames of a `width`×`height` animation, frame-major,
/// ids 0..n in hand-out order. One frame gives exactly [`decompose`]'s items.
pub fn decompose_frames(
    width: u32,
    height: u32,
    frames: u32,
    chunk: Chunk,
    order: Order,
) -> Vec<WorkItem> {
    let one = decompose(width, height, chunk, order);
    if frames == 1 {
        return one;
    }
    let n = one.len() as u32;
    (0..frames)
        .flat_map(|f| {
            one.iter().map(move |it| WorkItem {
                id: f * n + it.id,
                ..it.clone().in_frame(f)
            })
        })
        .collect()
}

/// Interleave the bits of x (even positions) and y (odd positions).
pub fn morton(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = v as u64;
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        v = (v | (v << 1)) & 0x5555_5555_5555_5555;
        v
    }
    spread(x) | (spread(y) << 1)
}

/// The (x, y) of Morton index `code` ([`morton`]'s inverse).
pub fn unmorton(code: u64) -> (u32, u32) {
    fn compact(v: u64) -> u32 {
        let mut v = v & 0x5555_5555_5555_5555;
        v = (v | (v >> 1)) & 0x3333_3333_3333_3333;
        v = (v | (v >> 2)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v >> 4)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v >> 8)) & 0x0000_ffff_0000_ffff;
        v = (v | (v >> 16)) & 0x0000_0000_ffff_ffff;
        v as u32
    }
    (compact(code), compact(code >> 1))
}

/// The (x, y) of stratified index `k` < side² in a `side`×`side` square ([`scatter`]'s
/// inverse: the bit reversal is its own inverse).
pub fn unscatter(side: u32, k: u64) -> (u32, u32) {
    let bits = 2 * side.max(1).trailing_zeros();
    if bits == 0 {
        return (0, 0);
    }
    unmorton(k.reverse_bits() >> (64 - bits))
}

/// The stratified index of (x, y) in a `side`×`side` square (side a power of two): its Morton
/// index with the 2·log₂(side) bits reversed, so the lowest bits of x and y decide first. Cells
/// 4ᵏ·j … 4ᵏ·(j+1) − 1 of a full square then hold one cell of each block of side/2ᵏ.
pub fn scatter(side: u32, x: u32, y: u32) -> u64 {
    let bits = 2 * side.max(1).trailing_zeros();
    if bits == 0 {
        return 0;
    }
    morton(x, y).reverse_bits() >> (64 - bits)
}

/// The cells of a `gx`×`gy` grid in a square spiral from the centre cell (⌊gx/2⌋, ⌊gy/2⌋)
/// outward: right 1, down 1, left 2, up 2, right 3, … skipping steps outside the grid, as
/// Mitsuba's `Spiral` walks its blocks. Each leg is clipped to the grid at once, so a long
/// grid costs its cells plus a constant per leg (M-124).
pub fn spiral(gx: u32, gy: u32) -> Vec<(u32, u32)> {
    let total = gx as usize * gy as usize;
    let mut out = Vec::with_capacity(total);
    if total == 0 {
        return out;
    }
    let (gx, gy) = (gx as i64, gy as i64);
    let (mut x, mut y) = (gx / 2, gy / 2);
    let dirs = [(1i64, 0i64), (0, 1), (-1, 0), (0, -1)];
    let (mut leg, mut d) = (1i64, 0usize);
    out.push((x as u32, y as u32));
    while out.len() < total {
        for _ in 0..2 {
            let (dx, dy) = dirs[d];
            // The steps k = 1..=leg whose cell lies inside the grid, in order.
            let (moving, fixed, m, f) = if dx != 0 {
                (x, y, gx, gy)
            } else {
                (y, x, gy, gx)
            };
            let step = dx + dy;
            if (0..f).contains(&fixed) {
                let (lo, hi) = if step > 0 {
                    (1.max(-moving), leg.min(m - 1 - moving))
                } else {
                    (1.max(moving - m + 1), leg.min(moving))
                };
                for k in lo..=hi {
                    let p = moving + step * k;
                    out.push(if dx != 0 {
                        (p as u32, fixed as u32)
                    } else {
                        (fixed as u32, p as u32)
                    });
                }
            }
            (x, y) = (x + dx * leg, y + dy * leg);
            d = (d + 1) % 4;
        }
        leg += 1;
    }
    out
}

/// Distance of (x, y) along the Hilbert curve filling a `side`×`side` square (side a power of
/// two), the classic rotate-and-flip formulation.
pub fn hilbert(side: u32, x: u32, y: u32) -> u64 {
    let (mut x, mut y) = (x as u64, y as u64);
    let n = side as u64;
    let mut d = 0u64;
    let mut s = n / 2;
    while s > 0 {
        let rx = u64::from(x & s > 0);
        let ry = u64::from(y & s > 0);
        d += s * s * ((3 * rx) ^ ry);
        if ry == 0 {
            if rx == 1 {
                x = n - 1 - x;
                y = n - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        s /= 2;
    }
    d
}

/// The (x, y) at distance `d` < side² along the Hilbert curve of a `side`×`side` square
/// ([`hilbert`]'s inverse, the same rotate-and-flip steps from the smallest square up).
pub fn unhilbert(side: u32, d: u64) -> (u32, u32) {
    let (mut x, mut y, mut t) = (0u64, 0u64, d);
    let mut s = 1u64;
    while s < side as u64 {
        let rx = 1 & (t / 2);
        let ry = 1 & (t ^ rx);
        if ry == 0 {
            if rx == 1 {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        x += s * rx;
        y += s * ry;
        t /= 4;
        s *= 2;
    }
    (x as u32, y as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coverage(w: u32, h: u32, items: &[WorkItem]) -> Vec<u32> {
        let mut seen = vec![0u32; (w * h) as usize];
        for it in items {
            for p in it.pixels(w) {
                seen[p as usize] += 1;
            }
        }
        seen
    }

    #[test]
    fn every_pixel_exactly_once_for_every_chunk_and_order() {
        let chunks = [
            Chunk::Tile { w: 1, h: 1 },
            Chunk::Tile { w: 4, h: 4 },
            Chunk::Tile { w: 5, h: 3 },
            Chunk::Tile { w: 64, h: 64 },
            Chunk::Rows(2),
            Chunk::Frame,
        ];
        for (w, h) in [(17, 13), (1, 1), (8, 8), (3, 40)] {
            for chunk in chunks {
                for order in Order::ALL {
                    let items = decompose(w, h, chunk, order);
                    assert!(
                        coverage(w, h, &items).iter().all(|&c| c == 1),
                        "{w}x{h} {chunk} {order:?}"
                    );
                    for (i, it) in items.iter().enumerate() {
                        assert_eq!(it.id, i as u32);
                    }
                }
            }
        }
    }

    #[test]
    fn frames_are_covered_once_each_in_frame_order() {
        for chunk in [
            Chunk::Tile { w: 1, h: 1 },
            Chunk::Tile { w: 4, h: 3 },
            Chunk::Frame,
        ] {
            let one = decompose(9, 7, chunk, Order::Hilbert);
            let items = decompose_frames(9, 7, 3, chunk, Order::Hilbert);
            assert_eq!(items.len(), 3 * one.len());
            assert_eq!(
                &items[..one.len()],
                &one[..],
                "frame 0 is the static decomposition"
            );
            for f in 0..3 {
                let of_f: Vec<WorkItem> =
                    items.iter().filter(|it| it.frame == f).cloned().collect();
                assert!(
                    coverage(9, 7, &of_f).iter().all(|&c| c == 1),
                    "{chunk} frame {f}"
                );
            }
            for (i, it) in items.iter().enumerate() {
                assert_eq!(it.id, i as u32);
                assert_eq!(it.frame, i as u32 / one.len() as u32, "frame-major");
            }
        }
        assert_eq!(
            decompose_frames(9, 7, 2, Chunk::Frame, Order::Scanline).len(),
            2
        );
    }

    #[test]
    fn hilbert_visits_neighbours_and_morton_is_z() {
        // Consecutive Hilbert cells are edge neighbours; Morton's first four cells form a Z.
        let items = decompose(8, 8, Chunk::Tile { w: 1, h: 1 }, Order::Hilbert);
        for pair in items.windows(2) {
            let p = |it: &WorkItem| match it.region {
                crate::core::render::Region::Rect { x, y, .. } => (x as i32, y as i32),
                _ => unreachable!(),
            };
            let ((x0, y0), (x1, y1)) = (p(&pair[0]), p(&pair[1]));
            assert_eq!((x0 - x1).abs() + (y0 - y1).abs(), 1);
        }
        let z: Vec<_> = decompose(4, 4, Chunk::Tile { w: 1, h: 1 }, Order::Morton)[..4]
            .iter()
            .map(|it| it.region.clone())
            .collect();
        use crate::core::render::Region::Rect;
        assert_eq!(
            z,
            vec![
                Rect {
                    x: 0,
                    y: 0,
                    w: 1,
                    h: 1
                },
                Rect {
                    x: 1,
                    y: 0,
                    w: 1,
                    h: 1
                },
                Rect {
                    x: 0,
                    y: 1,
                    w: 1,
                    h: 1
                },
                Rect {
                    x: 1,
                    y: 1,
                    w: 1,
                    h: 1
                }
            ]
        );
    }

    #[test]
    fn spiral_starts_at_the_centre_and_winds_outward() {
        // 3×3: centre, then right, down, left, left, up, up, right, right.
        assert_eq!(
            spiral(3, 3),
            [
                (1, 1),
                (2, 1),
                (2, 2),
                (1, 2),
                (0, 2),
                (0, 1),
                (0, 0),
                (1, 0),
                (2, 0)
            ]
        );
        // Each ring of a square grid is visited after the one inside it.
        let cells = spiral(8, 8);
        let ring = |&(x, y): &(u32, u32)| (x as i32 - 4).abs().max((y as i32 - 4).abs());
        assert!(cells.windows(2).all(|w| ring(&w[0]) <= ring(&w[1])));
        assert_eq!(cells.len(), 64);
        assert_eq!(spiral(1, 5).len(), 5);
        // Clipping each leg at once gives the cells of stepping through every position.
        let stepwise = |gx: u32, gy: u32| {
            let total = gx as usize * gy as usize;
            let mut out = Vec::new();
            let (mut x, mut y) = ((gx / 2) as i64, (gy / 2) as i64);
            let dirs = [(1i64, 0i64), (0, 1), (-1, 0), (0, -1)];
            let (mut leg, mut d) = (1i64, 0usize);
            out.push((x as u32, y as u32));
            while out.len() < total {
                for _ in 0..2 {
                    for _ in 0..leg {
                        (x, y) = (x + dirs[d].0, y + dirs[d].1);
                        if (0..gx as i64).contains(&x) && (0..gy as i64).contains(&y) {
                            out.push((x as u32, y as u32));
                        }
                    }
                    d = (d + 1) % 4;
                }
                leg += 1;
            }
            out
        };
        for gx in 1..=9 {
            for gy in 1..=9 {
                assert_eq!(spiral(gx, gy), stepwise(gx, gy), "{gx}×{gy}");
            }
        }
        for (gx, gy) in [(1, 40), (40, 1), (37, 3), (2, 31), (64, 64), (100, 7)] {
            assert_eq!(spiral(gx, gy), stepwise(gx, gy), "{gx}×{gy}");
        }
        assert!(spiral(0, 5).is_empty());
    }

    #[test]
    fn scatter_runs_sample_every_block_once() {
        // 8×8 cells: each aligned run of 4 holds one cell per 4×4 quadrant, each run of 16
        // one per 2×2 block, so a hot 2×2 block is shared by every run of 16.
        let items = decompose(8, 8, Chunk::Tile { w: 1, h: 1 }, Order::Scatter);
        let at = |it: &WorkItem| match it.region {
            crate::core::render::Region::Rect { x, y, .. } => (x, y),
            _ => unreachable!(),
        };
        for (run, side) in [(4, 4), (16, 2)] {
            for group in items.chunks(run) {
                let mut blocks: Vec<(u32, u32)> = group
                    .iter()
                    .map(|it| (at(it).0 / side, at(it).1 / side))
                    .collect();
                blocks.sort();
                blocks.dedup();
                assert_eq!(blocks.len(), run, "{run}: {blocks:?}");
            }
        }
        assert_eq!(at(&items[0]), (0, 0));
        assert_eq!(
            at(&items[1]),
            (0, 4),
            "the second cell is half the image away"
        );
        // A row of cells is stratified along its one axis: 0, 4, 2, 6, 1, 5, 3, 7.
        let row: Vec<u32> = decompose(8, 1, Chunk::Tile { w: 1, h: 1 }, Order::Scatter)
            .iter()
            .map(|it| at(it).0)
            .collect();
        assert_eq!(row, [0, 4, 2, 6, 1, 5, 3, 7]);
    }

    #[test]
    fn scatter_blocks_keep_each_block_together_and_stratify_the_blocks() {
        let at = |it: &WorkItem| match it.region {
            crate::core::render::Region::Rect { x, y, .. } => (x, y),
            _ => unreachable!(),
        };
        // 16×16 pixels = 4×4 blocks of 4² pixels: each aligned run of 16 one-pixel items is
        // one block in scanline order, each run of 64 holds one block per 8×8 quadrant.
        let items = decompose(16, 16, Chunk::Tile { w: 1, h: 1 }, Order::ScatterBlocks);
        for (b, run) in items.chunks(16).enumerate() {
            let (x0, y0) = at(&run[0]);
            assert_eq!((x0 % 4, y0 % 4), (0, 0), "block {b} starts at its corner");
            for (k, it) in run.iter().enumerate() {
                assert_eq!(at(it), (x0 + k as u32 % 4, y0 + k as u32 / 4), "block {b}");
            }
        }
        for group in items.chunks(64) {
            let mut quadrants: Vec<(u32, u32)> = group
                .iter()
                .map(|it| (at(it).0 / 8, at(it).1 / 8))
                .collect();
            quadrants.sort();
            quadrants.dedup();
            assert_eq!(quadrants.len(), 4);
        }
        assert_eq!(
            at(&items[16]),
            (0, 8),
            "the second block is half the image away"
        );
        // 2×2 tiles: blocks of 2×2 tiles, the same 4² pixels in the same block order.
        let tiles = decompose(16, 16, Chunk::Tile { w: 2, h: 2 }, Order::ScatterBlocks);
        assert_eq!(at(&tiles[3]), (2, 2));
        assert_eq!(at(&tiles[4]), (0, 8));
        // Cells of ≥ 4×4 pixels are their own blocks: the order is `scatter`.
        for chunk in [Chunk::Tile { w: 4, h: 4 }, Chunk::Tile { w: 5, h: 7 }] {
            for (w, h) in [(64, 64), (37, 21)] {
                assert_eq!(
                    decompose(w, h, chunk, Order::ScatterBlocks),
                    decompose(w, h, chunk, Order::Scatter),
                    "{w}x{h} {chunk}"
                );
            }
        }
    }

    #[test]
    fn keys_computed_once_sort_as_the_stable_sort_by_key() {
        for (gx, gy) in [(1, 1), (5, 3), (16, 16), (37, 9), (2, 64)] {
            let side = u32::max(gx, gy).next_power_of_two();
            let scanline = scanline_cells(gx, gy);
            let keys: [&dyn Fn(u32, u32) -> u64; 3] =
                [&morton, &|x, y| hilbert(side, x, y), &|x, y| {
                    scatter(side, x, y)
                }];
            for key in keys {
                let mut want = scanline.clone();
                want.sort_by_key(|&(x, y)| key(x, y));
                let mut got = scanline.clone();
                sort_cells(&mut got, key);
                assert_eq!(got, want, "{gx}×{gy}");
            }
            // Equal keys keep scanline order.
            let mut rows = scanline.clone();
            sort_cells(&mut rows, |_, y| y / 2);
            assert_eq!(rows, scanline, "{gx}×{gy}");
        }
    }

    #[test]
    fn walked_orders_are_the_orders_sorted_by_key() {
        // Square, near-square and long grids: the walk on the first ones, the sort on the
        // long ones (more than four keys per cell), and partial blocks at the edges.
        for (gx, gy) in [
            (1, 1),
            (2, 1),
            (3, 3),
            (8, 8),
            (13, 7),
            (16, 9),
            (40, 3),
            (1, 33),
        ] {
            let side = u32::max(gx, gy).next_power_of_two();
            let reference = |key: &dyn Fn(u32, u32) -> (u64, u32, u32)| {
                let mut c = scanline_cells(gx, gy);
                c.sort_by_key(|&(x, y)| key(x, y));
                c
            };
            let cases: [(Order, Vec<(u32, u32)>); 3] = [
                (Order::Morton, reference(&|x, y| (morton(x, y), 0, 0))),
                (
                    Order::Hilbert,
                    reference(&|x, y| (hilbert(side, x, y), 0, 0)),
                ),
                (
                    Order::Scatter,
                    reference(&|x, y| (scatter(side, x, y), 0, 0)),
                ),
            ];
            for (order, want) in cases {
                assert_eq!(
                    cells_in_order(gx, gy, (1, 1), order),
                    want,
                    "{order:?} {gx}×{gy}"
                );
            }
            for (cw, ch) in [(1, 1), (2, 1), (3, 5), (4, 4)] {
                let (bw, bh) = (BLOCK_PX.div_ceil(cw), BLOCK_PX.div_ceil(ch));
                let bside = gx.div_ceil(bw).max(gy.div_ceil(bh)).next_power_of_two();
                let want = reference(&|x, y| (scatter(bside, x / bw, y / bh), y % bh, x % bw));
                let got = cells_in_order(gx, gy, (cw, ch), Order::ScatterBlocks);
                assert_eq!(got, want, "scatter_blocks {gx}×{gy} cells {cw}×{ch}");
            }
        }
        for side in [1u32, 2, 4, 16, 64] {
            for k in 0..u64::from(side * side) {
                let (x, y) = unscatter(side, k);
                assert_eq!(scatter(side, x, y), k);
                let (x, y) = unhilbert(side, k);
                assert_eq!(hilbert(side, x, y), k);
                assert_eq!(morton(unmorton(k).0, unmorton(k).1), k);
            }
        }
    }

    #[test]
    fn chunk_larger_than_image_is_one_item() {
        let items = decompose(5, 3, Chunk::Tile { w: 64, h: 64 }, Order::Hilbert);
        assert_eq!(items, vec![WorkItem::rect(0, 0, 0, 5, 3)]);
    }
}
