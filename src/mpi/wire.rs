//! Decoders for the item/result layout of [`crate::sched::wire`], and the messages only the MPI
//! protocol has: the scene package rank 0 broadcasts and the READY answer of each worker.

use crate::core::render::{Region, TileResult, WorkItem};
use crate::core::scene::SceneOverrides;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("malformed {what} message: {msg}")]
/// A message that could not be decoded (too short, bad UTF-8, bad overrides).
pub struct WireError {
    /// Which message (`item`, `result`, `scene package`, `ready`, …).
    pub what: &'static str,
    /// What was wrong with it.
    pub msg: String,
}

/// A little-endian reader over a byte slice that fails instead of panicking.
pub struct Reader<'a> {
    bytes: &'a [u8],
    what: &'static str,
}

impl<'a> Reader<'a> {
    /// A reader over `bytes`; `what` names the message in errors.
    pub fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Self { bytes, what }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], WireError> {
        if self.bytes.len() < n {
            return Err(WireError {
                what: self.what,
                msg: format!("needs {n} more bytes, {} left", self.bytes.len()),
            });
        }
        let (a, b) = self.bytes.split_at(n);
        self.bytes = b;
        Ok(a)
    }
    /// The next byte.
    pub fn u8(&mut self) -> Result<u8, WireError> {
        Ok(self.take(1)?[0])
    }
    /// The next little-endian `u32`.
    pub fn u32(&mut self) -> Result<u32, WireError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    /// The next little-endian `u64`.
    pub fn u64(&mut self) -> Result<u64, WireError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    /// The next little-endian `f32`.
    pub fn f32(&mut self) -> Result<f32, WireError> {
        Ok(f32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    /// A `u64` length, then that many bytes (the layout [`put_bytes`] writes).
    pub fn bytes(&mut self) -> Result<&'a [u8], WireError> {
        let n = self.u64()? as usize;
        self.take(n)
    }
    /// A length-prefixed UTF-8 string (see [`Reader::bytes`]).
    pub fn string(&mut self) -> Result<String, WireError> {
        let b = self.bytes()?;
        String::from_utf8(b.to_vec()).map_err(|e| WireError {
            what: self.what,
            msg: e.to_string(),
        })
    }
    /// The bytes not read yet.
    pub fn rest(&self) -> &'a [u8] {
        self.bytes
    }
}

/// Append `b` with its length first (`u64`, little-endian).
pub fn put_bytes(out: &mut Vec<u8>, b: &[u8]) {
    out.extend_from_slice(&(b.len() as u64).to_le_bytes());
    out.extend_from_slice(b);
}

/// Inverse of [`crate::sched::wire::encode_item`].
pub fn decode_item(bytes: &[u8]) -> Result<WorkItem, WireError> {
    decode_item_prefix(bytes).map(|(item, _)| item)
}

/// An ITEM message: one or more items back to back (one hand-out of the master).
pub fn decode_items(mut bytes: &[u8]) -> Result<Vec<WorkItem>, WireError> {
    let mut items = Vec::new();
    while !bytes.is_empty() {
        let (item, rest) = decode_item_prefix(bytes)?;
        items.push(item);
        bytes = rest;
    }
    Ok(items)
}

/// One item from the front of `bytes`, and the bytes after it.
fn decode_item_prefix(bytes: &[u8]) -> Result<(WorkItem, &[u8]), WireError> {
    let mut r = Reader::new(bytes, "item");
    let id = r.u32()?;
    let frame = r.u32()?;
    let region = match r.u8()? {
        0 => Region::Rect {
            x: r.u32()?,
            y: r.u32()?,
            w: r.u32()?,
            h: r.u32()?,
        },
        1 => {
            let n = r.u32()? as usize;
            if r.rest().len() < 4 * n {
                return Err(WireError {
                    what: "item",
                    msg: format!("{n} pixels announced, fewer sent"),
                });
            }
            Region::Pixels((0..n).map(|_| r.u32()).collect::<Result<_, _>>()?)
        }
        t => {
            return Err(WireError {
                what: "item",
                msg: format!("unknown region tag {t}"),
            })
        }
    };
    Ok((WorkItem { id, region, frame }, r.rest()))
}

/// A RESULT message: one or more entries back to back, each a result
/// ([`crate::sched::wire::encode_result`]) followed by the worker's busy time in ns (u64).
pub fn decode_results(mut bytes: &[u8]) -> Result<Vec<(TileResult, u64)>, WireError> {
    let mut out = Vec::new();
    while !bytes.is_empty() {
        let (r, rest) = decode_result(bytes)?;
        let mut busy = Reader::new(rest, "result busy time");
        out.push((r, busy.u64()?));
        bytes = busy.rest();
    }
    Ok(out)
}

/// Inverse of [`crate::sched::wire::encode_result`]; returns the bytes that follow it.
pub fn decode_result(bytes: &[u8]) -> Result<(TileResult, &[u8]), WireError> {
    let mut r = Reader::new(bytes, "result");
    let item = r.u32()?;
    let n = r.u32()? as usize;
    if r.rest().len() < 12 * n {
        return Err(WireError {
            what: "result",
            msg: format!("{n} pixels announced, fewer sent"),
        });
    }
    let mut pixels = crate::core::render::PixelValues::with_capacity(n);
    for _ in 0..n {
        pixels.push([r.f32()?, r.f32()?, r.f32()?]);
    }
    let rays = r.u64()?;
    let nonfinite = r.u64()?;
    Ok((
        TileResult {
            item,
            pixels,
            rays,
            nonfinite,
        },
        r.rest(),
    ))
}

/// Everything a worker rank needs to build the scene and tracer rank 0 has: no shared
/// filesystem is assumed, so mesh files travel as bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct ScenePackage {
    /// The scene file's text, exactly as read.
    pub text: String,
    /// How errors name the scene (rank 0's path).
    pub display: String,
    /// The scene's name (rank 0's file stem).
    pub name: String,
    /// Overrides of the scene's settings (size, spp, …), applied on every rank alike.
    pub overrides: SceneOverrides,
    /// (path as written in the scene, file bytes) of every mesh.
    pub meshes: Vec<(String, Vec<u8>)>,
    /// The tracer's id (`TracerKind::from_id`).
    pub tracer: String,
    /// Rank 0's `Scene::hash`; every worker checks its own against it.
    pub hash: u64,
}

impl ScenePackage {
    /// The package as one message (length-prefixed fields, little-endian).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::new();
        put_bytes(&mut out, self.text.as_bytes());
        put_bytes(&mut out, self.display.as_bytes());
        put_bytes(&mut out, self.name.as_bytes());
        let ov = toml::to_string(&self.overrides).expect("overrides serialise");
        put_bytes(&mut out, ov.as_bytes());
        out.extend_from_slice(&(self.meshes.len() as u64).to_le_bytes());
        for (p, b) in &self.meshes {
            put_bytes(&mut out, p.as_bytes());
            put_bytes(&mut out, b);
        }
        put_bytes(&mut out, self.tracer.as_bytes());
        out.extend_from_slice(&self.hash.to_le_bytes());
        out
    }

    /// Inverse of [`ScenePackage::encode`].
    pub fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(bytes, "scene package");
        let text = r.string()?;
        let display = r.string()?;
        let name = r.string()?;
        let ov = r.string()?;
        let overrides = toml::from_str(&ov).map_err(|e| WireError {
            what: "scene package",
            msg: e.to_string(),
        })?;
        let n = r.u64()?;
        let mut meshes = Vec::new();
        for _ in 0..n {
            meshes.push((r.string()?, r.bytes()?.to_vec()));
        }
        let tracer = r.string()?;
        let hash = r.u64()?;
        Ok(Self {
            text,
            display,
            name,
            overrides,
            meshes,
            tracer,
            hash,
        })
    }
}

/// A worker's answer after building the scene: its pid and host (so rank 0 can notice a local
/// rank that died) and an error message, empty when all went well.
#[derive(Clone, Debug, PartialEq)]
pub struct Ready {
    /// The worker's process id.
    pub pid: u32,
    /// The host the worker runs on.
    pub host: String,
    /// Why the scene could not be built; empty on success.
    pub error: String,
}

impl Ready {
    /// The answer as one READY message: pid, then length-prefixed host and error.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.pid.to_le_bytes().to_vec();
        put_bytes(&mut out, self.host.as_bytes());
        put_bytes(&mut out, self.error.as_bytes());
        out
    }
    /// Inverse of [`Ready::encode`].
    pub fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(bytes, "ready");
        Ok(Self {
            pid: r.u32()?,
            host: r.string()?,
            error: r.string()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::wire::{encode_item, encode_result};

    #[test]
    fn items_and_results_round_trip() {
        for item in [
            WorkItem::rect(3, 1, 2, 16, 16),
            WorkItem::rect(3, 1, 2, 16, 16).in_frame(5),
            WorkItem {
                id: 9,
                region: Region::Pixels(vec![1, 5, 7]),
                frame: 1,
            },
        ] {
            let mut b = Vec::new();
            encode_item(&item, &mut b);
            assert_eq!(decode_item(&b).unwrap(), item);
            assert!(decode_item(&b[..b.len() - 1]).is_err());
        }
        let r = TileResult {
            item: 3,
            pixels: smallvec::smallvec![[1.0, -2.5, f32::MAX]; 5],
            rays: 7,
            nonfinite: 2,
        };
        let mut b = Vec::new();
        encode_result(&r, &mut b);
        b.extend_from_slice(&42u64.to_le_bytes());
        let (back, rest) = decode_result(&b).unwrap();
        assert_eq!(back, r);
        assert_eq!(rest, 42u64.to_le_bytes());
        assert!(decode_result(&b[..10]).is_err());
    }

    #[test]
    fn several_items_and_results_share_one_message() {
        let items = [
            WorkItem::rect(0, 0, 0, 1, 1),
            WorkItem {
                id: 1,
                region: Region::Pixels(vec![4, 2]),
                frame: 3,
            },
            WorkItem::rect(2, 5, 6, 7, 8),
        ];
        let mut b = Vec::new();
        for it in &items {
            encode_item(it, &mut b);
        }
        assert_eq!(decode_items(&b).unwrap(), items);
        assert!(decode_items(&b[..b.len() - 2]).is_err(), "a torn last item");
        let results: Vec<_> = (0..3u32)
            .map(|i| TileResult {
                item: i,
                pixels: smallvec::smallvec![[i as f32, 0.5, -1.0]; i as usize],
                rays: 10 + i as u64,
                nonfinite: i as u64,
            })
            .collect();
        let mut b = Vec::new();
        for (i, r) in results.iter().enumerate() {
            encode_result(r, &mut b);
            b.extend_from_slice(&(100 + i as u64).to_le_bytes());
        }
        let back = decode_results(&b).unwrap();
        assert_eq!(back.len(), 3);
        for (i, (r, busy)) in back.into_iter().enumerate() {
            assert_eq!((r, busy), (results[i].clone(), 100 + i as u64));
        }
        assert!(
            decode_results(&b[..b.len() - 3]).is_err(),
            "a torn busy time"
        );
    }

    #[test]
    fn packages_round_trip() {
        let p = ScenePackage {
            text: "[camera]\n".into(),
            display: "scenes/x.toml".into(),
            name: "x".into(),
            overrides: SceneOverrides {
                spp: Some(3),
                ..Default::default()
            },
            meshes: vec![("m/a.obj".into(), vec![1, 2, 3])],
            tracer: "bvh".into(),
            hash: 0xdead_beef,
        };
        assert_eq!(ScenePackage::decode(&p.encode()).unwrap(), p);
        assert!(ScenePackage::decode(&p.encode()[..20]).is_err());
        let r = Ready {
            pid: 12,
            host: "h".into(),
            error: String::new(),
        };
        assert_eq!(Ready::decode(&r.encode()).unwrap(), r);
    }
}
