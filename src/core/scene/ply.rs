//! `type = "ply"`: the faces of a PLY file (ASCII, binary little- or big-endian), read with the
//! maintained `ply-rs-bw` crate (a fork of the dormant `ply-rs`) through its typed
//! `PropertyAccess` path, so no per-vertex hash map is built.
//!
//! ```toml
//! [[shapes]]
//! type = "ply"
//! material = "grey"
//! path = "models/bunny.ply"          # relative to the scene file
//! ```
//!
//! Read: element `vertex` with `x`, `y`, `z` of type `float` or `double`, and element `face`
//! with a list `vertex_indices` (or `vertex_index`) of any integer type. A polygon is split into
//! a fan around its first vertex (exact for convex polygons; the usual reading of PLY faces).
//! Every other element and property (normals, colours, texture coordinates, `edge`, `material`)
//! is skipped; a file without faces (a point cloud) is an error.

use crate::util::hash::Fnv64;
use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    ElementDef, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};
use std::io::BufReader;
use std::path::Path;

/// One vertex: only its position.
#[derive(Default)]
struct Vertex([f64; 3]);

impl Vertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        match name {
            "x" => self.0[0] = v,
            "y" => self.0[1] = v,
            "z" => self.0[2] = v,
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, f64::from(v))
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v)
    }
}

/// One face: its vertex indices, widened to i64 so a negative index stays visible.
#[derive(Default)]
struct Face(Vec<i64>);

impl Face {
    fn set<T: Into<i64>>(&mut self, name: &str, v: Vec<T>) -> PropertyAccessResult {
        if name == "vertex_indices" || name == "vertex_index" {
            self.0 = v.into_iter().map(Into::into).collect();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, n: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uchar(&mut self, n: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_short(&mut self, n: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_ushort(&mut self, n: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_int(&mut self, n: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uint(&mut self, n: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(n, v)
    }
}

/// An element read only to get past it.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// The triangles of `path` (its bytes are fed to `hash`).
///
/// # Errors
/// One line naming the element (and its index where one is at fault): unreadable file, bad
/// header, vertex coordinates missing or not float/double, no faces, a truncated or malformed
/// payload, an index out of range, a non-finite coordinate, or no triangle at all.
pub fn read_ply(path: &Path, hash: &mut Fnv64) -> Result<Vec<[DVec3; 3]>, PlyError> {
    read_triangles(path, hash).map_err(PlyError)
}

/// A PLY file that does not read as a triangle mesh: one line naming the element (and its
/// index where one is at fault).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct PlyError(pub String);

fn read_triangles(path: &Path, hash: &mut Fnv64) -> Result<Vec<[DVec3; 3]>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    hash.write(&bytes);
    let bytes = tolerant_header(bytes);
    let mut reader = ply_rs_bw::parser::Reader::new(BufReader::new(&bytes[..]));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| format!("header: {}", flat(&e.to_string())))?;
    check_header(&header)?;
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    for (name, def) in &header.elements {
        let payload_err = |e: ply_rs_bw::parser::ParseError| {
            format!("element '{name}': {}", flat(&e.to_string()))
        };
        match name.as_str() {
            "vertex" => {
                vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(payload_err)?
                    .into_iter()
                    .map(|v| DVec3::from_array(v.0))
                    .collect();
            }
            "face" => {
                faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(payload_err)?;
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(payload_err)?;
            }
        }
    }
    if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
        return Err(format!("vertex {i}: coordinate is not finite"));
    }
    let mut tris = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let mut corner = Vec::with_capacity(face.0.len());
        for &i in &face.0 {
            match usize::try_from(i).ok().and_then(|i| vertices.get(i)) {
                Some(v) => corner.push(*v),
                None => {
                    return Err(format!(
                        "face {f}: vertex index {i} is out of range ({} vertices)",
                        vertices.len()
                    ))
                }
            }
        }
        for k in 1..corner.len().saturating_sub(1) {
            tris.push([corner[0], corner[k], corner[k + 1]]);
        }
    }
    if tris.is_empty() {
        return Err("element 'face': no polygon with 3 or more vertices".into());
    }
    Ok(tris)
}

/// Header keywords of the PLY format.
const KEYWORDS: [&str; 7] = [
    "ply",
    "format",
    "comment",
    "obj_info",
    "element",
    "property",
    "end_header",
];

/// `bytes` with every header line that starts with no PLY keyword turned into a comment:
/// Blender 2.47 writes its banner ("Created by Blender3D …") as a bare header line, which
/// other readers (assimp among them) skip.
fn tolerant_header(bytes: Vec<u8>) -> Vec<u8> {
    let Some(end) = bytes.windows(10).position(|w| w == b"end_header") else {
        return bytes; // the parser reports the missing end
    };
    let Ok(head) = std::str::from_utf8(&bytes[..end]) else {
        return bytes;
    };
    let bare = |l: &str| {
        let w = l.split_whitespace().next();
        w.is_some_and(|w| !KEYWORDS.contains(&w))
    };
    if !head.lines().any(bare) {
        return bytes;
    }
    let mut out = String::with_capacity(end + 64);
    for l in head.split_inclusive('\n') {
        if bare(l) {
            out.push_str("comment ");
        }
        out.push_str(l);
    }
    let mut out = out.into_bytes();
    out.extend_from_slice(&bytes[end..]);
    out
}

/// The header describes a triangle mesh this reader understands.
fn check_header(h: &Header) -> Result<(), String> {
    let vertex = h.elements.get("vertex").ok_or("has no element 'vertex'")?;
    for axis in ["x", "y", "z"] {
        coordinate_type(vertex, axis)?;
    }
    let face = h
        .elements
        .get("face")
        .ok_or("has no element 'face' (a point cloud has nothing to render)")?;
    let list = face
        .properties
        .get("vertex_indices")
        .or_else(|| face.properties.get("vertex_index"))
        .ok_or("element 'face' has no property 'vertex_indices'")?;
    match &list.data_type {
        PropertyType::List(_, t) if is_integer(t) => Ok(()),
        other => Err(format!(
            "element 'face': property '{}' must be a list of integers (got {other:?})",
            list.name
        )),
    }
}

fn coordinate_type(vertex: &ElementDef, axis: &str) -> Result<(), String> {
    let p = vertex
        .properties
        .get(axis)
        .ok_or_else(|| format!("element 'vertex' has no property '{axis}'"))?;
    match p.data_type {
        PropertyType::Scalar(ScalarType::Float | ScalarType::Double) => Ok(()),
        ref other => Err(format!(
            "element 'vertex': property '{axis}' must be float or double (got {other:?})"
        )),
    }
}

fn is_integer(t: &ScalarType) -> bool {
    !matches!(t, ScalarType::Float | ScalarType::Double)
}

/// The crate's multi-line messages on one line.
fn flat(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &[u8]) -> Result<Vec<[DVec3; 3]>, String> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.ply");
        std::fs::write(&p, text).unwrap();
        read_ply(&p, &mut Fnv64::default()).map_err(|e| e.0)
    }

    const QUAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nelement face 1\n\
        property list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    #[test]
    fn an_ascii_quad_is_two_triangles_of_a_fan() {
        let t = read(QUAD.as_bytes()).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[1], [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    }

    #[test]
    fn binary_big_and_little_endian_read_the_same_triangle() {
        for (fmt, be) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut b = format!(
                "ply\nformat {fmt} 1.0\nelement vertex 3\nproperty double x\n\
                 property double y\nproperty double z\nelement face 1\n\
                 property list uchar uint vertex_indices\nend_header\n"
            )
            .into_bytes();
            for v in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.5]] {
                for x in v {
                    b.extend(if be { x.to_be_bytes() } else { x.to_le_bytes() });
                }
            }
            b.push(3);
            for i in 0u32..3 {
                b.extend(if be { i.to_be_bytes() } else { i.to_le_bytes() });
            }
            let t = read(&b).unwrap_or_else(|e| panic!("{fmt}: {e}"));
            assert_eq!(
                t,
                vec![[
                    DVec3::ZERO,
                    DVec3::new(2.0, 0.0, 0.0),
                    DVec3::new(0.0, 3.0, 0.5)
                ]]
            );
        }
    }

    #[test]
    fn bad_files_are_one_line_errors_naming_the_element() {
        let out_of_range = QUAD.replace("4 0 1 2 3", "4 0 1 2 9");
        let e = read(out_of_range.as_bytes()).unwrap_err();
        assert_eq!(e, "face 0: vertex index 9 is out of range (4 vertices)");
        let truncated = QUAD.replace("4 0 1 2 3\n", "");
        let e = read(truncated.as_bytes()).unwrap_err();
        assert!(e.starts_with("element 'face':") && !e.contains('\n'), "{e}");
        let ints = QUAD.replace("property float y", "property int y");
        let e = read(ints.as_bytes()).unwrap_err();
        assert!(
            e.starts_with("element 'vertex': property 'y' must be float"),
            "{e}"
        );
        let points = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n\
            property float y\nproperty float z\nend_header\n0 0 0\n";
        assert!(read(points.as_bytes()).unwrap_err().contains("point cloud"));
        let banner = QUAD.replace(
            "format ascii 1.0\n",
            "format ascii 1.0\nCreated by Blender3D\n",
        );
        assert_eq!(read(banner.as_bytes()).unwrap().len(), 2);
        let nan = QUAD.replace("1 1 0", "nan 1 0");
        let e = read(nan.as_bytes()).unwrap_err();
        assert!(
            e.starts_with("element 'vertex'") || e.starts_with("vertex 2"),
            "{e}"
        );
    }
}
