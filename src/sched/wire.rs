//! Byte sizes of items and results on the wire, from a documented fixed little-endian layout
//! (what an MPI source sends). [`encode_item`]/[`encode_result`] write exactly that layout, so
//! the sizes are checked against real bytes in the tests; the schedulers only need the sizes.
//!
//! ```text
//! WorkItem  Rect:   id u32 | frame u32 | tag u8 = 0 | x u32 | y u32 | w u32 | h u32 = 25 bytes
//!           Pixels: id u32 | frame u32 | tag u8 = 1 | n u32 | n × u32             = 13 + 4n
//! TileResult:       item u32 | n u32 | n × [f32; 3] | rays u64 | nonfinite u64   = 24 + 12n
//! ```

use crate::core::render::{Region, TileResult, WorkItem};

/// Encoded size of `item` in bytes (what [`encode_item`] writes).
pub fn item_bytes(item: &WorkItem) -> u64 {
    match &item.region {
        Region::Rect { .. } => 25,
        Region::Pixels(p) => 13 + 4 * p.len() as u64,
    }
}

/// Encoded size of `result` in bytes (what [`encode_result`] writes).
pub fn result_bytes(result: &TileResult) -> u64 {
    24 + 12 * result.pixels.len() as u64
}

/// Append `item` to `out` in the layout above.
pub fn encode_item(item: &WorkItem, out: &mut Vec<u8>) {
    out.extend_from_slice(&item.id.to_le_bytes());
    out.extend_from_slice(&item.frame.to_le_bytes());
    match &item.region {
        Region::Rect { x, y, w, h } => {
            out.push(0);
            for v in [x, y, w, h] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        Region::Pixels(p) => {
            out.push(1);
            out.extend_from_slice(&(p.len() as u32).to_le_bytes());
            for v in p {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
}

/// Append `r` to `out` in the layout above.
pub fn encode_result(r: &TileResult, out: &mut Vec<u8>) {
    out.extend_from_slice(&r.item.to_le_bytes());
    out.extend_from_slice(&(r.pixels.len() as u32).to_le_bytes());
    for px in &r.pixels {
        for c in px {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out.extend_from_slice(&r.rays.to_le_bytes());
    out.extend_from_slice(&r.nonfinite.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_match_the_encoded_bytes() {
        for item in [
            WorkItem::rect(3, 1, 2, 16, 16),
            WorkItem::rect(3, 1, 2, 16, 16).in_frame(7),
            WorkItem {
                id: 9,
                region: Region::Pixels(vec![1, 5, 7]),
                frame: 2,
            },
        ] {
            let mut b = Vec::new();
            encode_item(&item, &mut b);
            assert_eq!(b.len() as u64, item_bytes(&item));
            assert_eq!(b[4..8], item.frame.to_le_bytes(), "frame follows the id");
        }
        assert_eq!(item_bytes(&WorkItem::rect(0, 0, 0, 1, 1)), 25);
        let r = TileResult {
            item: 3,
            pixels: smallvec::smallvec![[1.0, 2.0, 3.0]; 256],
            rays: 7,
            nonfinite: 0,
        };
        let mut b = Vec::new();
        encode_result(&r, &mut b);
        assert_eq!(b.len() as u64, result_bytes(&r));
        assert_eq!(result_bytes(&r), 24 + 12 * 256);
    }
}
