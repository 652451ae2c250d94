//! `type = "gltf"`: the triangles and materials of a glTF 2.0 file (`.gltf` with its buffers,
//! or `.glb`), read with the `gltf` crate.
//!
//! ```toml
//! [[shapes]]
//! type = "gltf"
//! path = "models/duck.glb"            # relative to the scene file
//! transform = [{ scale = 0.01 }]      # applied after the file's own node transforms
//! # material = "grey"                 # optional: replaces every material of the file
//! ```
//!
//! What is read: the default scene (`scene`, else the first scene) with its node hierarchy and
//! each node's transform, and every primitive of mode triangles, triangle strip or triangle fan
//! (indexed or not; strips and fans are split into triangles with the winding glTF defines).
//!
//! Materials (metallic-roughness), one raysched material per glTF material:
//! - `KHR_materials_transmission` with `transmissionFactor` ≥ 0.5 → `dielectric` with the
//!   `KHR_materials_ior` index (glTF's default 1.5);
//! - else `metallicFactor` = 1 and `roughnessFactor` ≤ [`MIRROR_MAX_ROUGHNESS`] → `mirror`
//!   reflecting the base colour factor;
//! - else → `diffuse` with the base colour factor's RGB as reflectance (alpha ignored);
//! - `emissiveFactor` × `KHR_materials_emissive_strength` > 0 → those triangles are also an area
//!   emitter of that radiance (one area light per emitting primitive);
//! - a primitive without a material gets glTF's default material (white, metallic 1,
//!   roughness 1: white diffuse).
//!
//! The shape's `material` replaces all of that, and its `emission` makes the whole shape one area
//! light instead of the file's emissive materials.
//!
//! What the renderer cannot show is named in [`GltfMesh::ignored`], which the run reports among
//! its left-out features (`gltf_textures`, `gltf_skins`, …): textures (only the factors are
//! used), texture transforms, skins, morph targets, animations, cameras, punctual lights, vertex
//! normals and colours (shading uses the flat triangle normal), point and line primitives, and
//! every other extension by name (`gltf_ext_KHR_materials_clearcoat`). A file whose
//! `extensionsRequired` names an extension this reader lacks (Draco compression,
//! `KHR_draco_mesh_compression`, above all) is an error saying so.

use crate::util::hash::Fnv64;
use glam::{DMat4, DVec3, Vec3};
use gltf::mesh::Mode;
use std::collections::BTreeSet;
use std::path::Path;

/// Largest `roughnessFactor` of a fully metallic material that still becomes a perfect mirror.
pub const MIRROR_MAX_ROUGHNESS: f32 = 0.2;

/// Smallest `transmissionFactor` that makes a material a dielectric.
pub const MIN_TRANSMISSION: f32 = 0.5;

/// Deepest node hierarchy read; deeper means a cycle (which the spec forbids) or a bad file.
const MAX_NODE_DEPTH: usize = 256;

/// Extensions this reader understands well enough that a file may require them.
const SUPPORTED_REQUIRED: [&str; 4] = [
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_emissive_strength",
    // Texture transforms change only texture lookups, and textures are left out anyway.
    "KHR_texture_transform",
];

/// Extensions whose effect is read (the rest are reported as ignored).
const READ_EXTENSIONS: [&str; 3] = [
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_emissive_strength",
];

/// How one glTF material is rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MappedSurface {
    /// Lambertian with this reflectance.
    Diffuse(Vec3),
    /// Perfect mirror with this reflectance.
    Mirror(Vec3),
    /// Smooth dielectric with this interior index.
    Dielectric(f32),
}

/// One glTF material as raysched renders it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MappedMaterial {
    /// How it scatters.
    pub surface: MappedSurface,
    /// Emitted radiance (zero when it does not emit).
    pub emission: DVec3,
}

/// The triangles of one primitive, in the file's scene space (node transforms applied).
#[derive(Clone, Debug)]
pub struct GltfPart {
    /// Index into [`GltfMesh::materials`].
    pub material: usize,
    /// Triangles, counter-clockwise seen from the front.
    pub triangles: Vec<[DVec3; 3]>,
}

/// What a glTF file holds that raysched renders.
#[derive(Clone, Debug)]
pub struct GltfMesh {
    /// The file's materials in file order, then glTF's default material.
    pub materials: Vec<MappedMaterial>,
    /// One part per triangle primitive instance (a mesh used by two nodes gives two parts).
    pub parts: Vec<GltfPart>,
    /// Whether the file defines any material of its own.
    pub has_materials: bool,
    /// What the file uses that is not rendered, as left-out feature names.
    pub ignored: BTreeSet<String>,
}

impl GltfMesh {
    /// Number of triangles over every part.
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.triangles.len()).sum()
    }
}

/// Why a glTF file was refused: one line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct GltfError(pub String);

/// Read `path` (its bytes and every buffer it loads are fed to `hash`).
///
/// # Errors
/// One line: unreadable file or buffer, invalid glTF (the first problem the validator names),
/// an unsupported required extension, an index out of range, or no triangle at all.
pub fn read_gltf(path: &Path, hash: &mut Fnv64) -> Result<GltfMesh, GltfError> {
    read(path, hash).map_err(GltfError)
}

fn read(path: &Path, hash: &mut Fnv64) -> Result<GltfMesh, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    hash.write(&bytes);
    if is_gltf1(&bytes) {
        return Err("is glTF 1.0; raysched reads glTF 2.0 only".into());
    }
    let unchecked = gltf::Gltf::from_slice_without_validation(&bytes).map_err(one_line)?;
    for ext in unchecked.extensions_required() {
        if !SUPPORTED_REQUIRED.contains(&ext) {
            return Err(unsupported_required(ext));
        }
    }
    let gltf::Gltf { document, blob } = unchecked;
    let root = document.into_json();
    position_accessors_in_range(&root)?;
    let document = gltf::Document::from_json(root).map_err(one_line)?;
    let buffers = gltf::import_buffers(&document, path.parent(), blob).map_err(one_line)?;
    for b in &buffers {
        hash.write(&b.0);
    }
    let mut ignored = document_ignored(&document);
    let materials = document
        .materials()
        .map(|m| map_material(&m, &mut ignored))
        // glTF's default material: base colour 1, metallic 1, roughness 1, no emission.
        .chain(std::iter::once(MappedMaterial {
            surface: MappedSurface::Diffuse(Vec3::ONE),
            emission: DVec3::ZERO,
        }))
        .collect::<Vec<_>>();
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or("has no scene (nothing to show)")?;
    let mut reader = Reader {
        buffers: &buffers,
        default_material: materials.len() - 1,
        parts: Vec::new(),
        ignored,
    };
    for node in scene.nodes() {
        reader.node(&node, DMat4::IDENTITY, 0)?;
    }
    let mut mesh = GltfMesh {
        materials,
        parts: reader.parts,
        has_materials: document.materials().len() > 0,
        ignored: reader.ignored,
    };
    mesh.parts.retain(|p| !p.triangles.is_empty());
    if mesh.triangle_count() == 0 {
        let why = if mesh.ignored.contains("gltf_points_lines") {
            "has no triangles (only point or line primitives)"
        } else {
            "has no triangles in its default scene"
        };
        return Err(why.into());
    }
    Ok(mesh)
}

/// The relative file names of the buffers a `.gltf` file loads (embedded `data:` buffers and a
/// `.glb`'s own chunk excluded), as the file writes them, percent-decoding left to the reader.
///
/// # Errors
/// The file cannot be read or is not glTF JSON.
pub fn external_buffers(path: &Path) -> Result<Vec<String>, GltfError> {
    buffer_uris(path).map_err(GltfError)
}

fn buffer_uris(path: &Path) -> Result<Vec<String>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    let g = gltf::Gltf::from_slice_without_validation(&bytes).map_err(one_line)?;
    Ok(g.buffers()
        .filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(u) if !u.starts_with("data:") => Some(u.to_string()),
            _ => None,
        })
        .collect())
}

/// A glTF 1.0 file: a binary container of version 1, or JSON whose `asset.version` is "1.x"
/// (or the number 1, as some converters wrote it).
fn is_gltf1(bytes: &[u8]) -> bool {
    if bytes.starts_with(b"glTF") {
        return bytes.get(4..8) == Some(&1u32.to_le_bytes()[..]);
    }
    gltf::json::deserialize::from_slice::<gltf::json::Value>(bytes).is_ok_and(|v| {
        v.get("asset")
            .and_then(|a| a.get("version"))
            .is_some_and(|v| {
                v.as_str().is_some_and(|s| s.starts_with("1."))
                    || v.as_f64().is_some_and(|x| (1.0..2.0).contains(&x))
            })
    })
}

/// The error for a required extension this reader lacks.
fn unsupported_required(ext: &str) -> String {
    let what = match ext {
        "KHR_draco_mesh_compression" => " (Draco-compressed meshes)",
        "KHR_mesh_quantization" => " (quantized vertex attributes)",
        "EXT_meshopt_compression" => " (meshopt-compressed buffers)",
        _ => "",
    };
    format!("requires the glTF extension {ext}{what}, which raysched does not support")
}

/// Every primitive's `POSITION` accessor exists. The validator of `gltf-json` 1.4 reads that
/// accessor by plain indexing before it checks the index, and panics on a file whose index is
/// out of range (a one-byte change to the shipped model found it); this check runs first.
fn position_accessors_in_range(root: &gltf::json::Root) -> Result<(), String> {
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(i) = prim.attributes.get(&position) {
                if i.value() >= accessors {
                    return Err(format!(
                        "invalid glTF: meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} of {accessors}",
                        i.value()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A `gltf` crate error on one line: validation lists every problem, keep the first.
fn one_line(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => {
            let more = list.len().saturating_sub(1);
            match list.first() {
                Some((path, err)) => {
                    let tail = if more > 0 {
                        format!(" (and {more} more problems)")
                    } else {
                        String::new()
                    };
                    format!("invalid glTF: {}: {err}{tail}", path.as_str())
                }
                None => "invalid glTF".into(),
            }
        }
        other => format!("invalid glTF: {}", other.to_string().replace('\n', " ")),
    }
}

/// Left-out features visible from the document alone.
fn document_ignored(d: &gltf::Document) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut add = |on: bool, name: &str| {
        if on {
            out.insert(name.to_string());
        }
    };
    add(d.skins().len() > 0, "gltf_skins");
    add(d.animations().len() > 0, "gltf_animations");
    add(d.cameras().len() > 0, "gltf_cameras");
    add(d.textures().len() > 0, "gltf_textures");
    for ext in d.extensions_used() {
        let name = match ext {
            e if READ_EXTENSIONS.contains(&e) => continue,
            "KHR_lights_punctual" => "gltf_lights".to_string(),
            "KHR_texture_transform" => "gltf_texture_transform".to_string(),
            "KHR_draco_mesh_compression" => "gltf_draco".to_string(),
            other => format!("gltf_ext_{other}"),
        };
        out.insert(name);
    }
    out
}

/// The stated mapping of one glTF material (module docs).
fn map_material(m: &gltf::Material, ignored: &mut BTreeSet<String>) -> MappedMaterial {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _alpha] = pbr.base_color_factor();
    let base = Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE);
    let textured = pbr.base_color_texture().is_some()
        || pbr.metallic_roughness_texture().is_some()
        || m.normal_texture().is_some()
        || m.occlusion_texture().is_some()
        || m.emissive_texture().is_some();
    if textured {
        ignored.insert("gltf_textures".into());
    }
    let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
    let surface = if transmission >= MIN_TRANSMISSION {
        MappedSurface::Dielectric(m.ior().filter(|i| i.is_finite() && *i > 0.0).unwrap_or(1.5))
    } else if pbr.metallic_factor() >= 1.0 && pbr.roughness_factor() <= MIRROR_MAX_ROUGHNESS {
        MappedSurface::Mirror(base)
    } else {
        MappedSurface::Diffuse(base)
    };
    let strength = m.emissive_strength().unwrap_or(1.0) as f64;
    let emission = DVec3::from_array(m.emissive_factor().map(f64::from)) * strength;
    let emission = if emission.is_finite() {
        emission.max(DVec3::ZERO)
    } else {
        DVec3::ZERO
    };
    MappedMaterial { surface, emission }
}

/// Walks the node hierarchy, gathering triangle parts.
struct Reader<'a> {
    buffers: &'a [gltf::buffer::Data],
    default_material: usize,
    parts: Vec<GltfPart>,
    ignored: BTreeSet<String>,
}

impl Reader<'_> {
    fn node(&mut self, node: &gltf::Node, parent: DMat4, depth: usize) -> Result<(), String> {
        if depth >= MAX_NODE_DEPTH {
            return Err(format!(
                "node {}: hierarchy deeper than {MAX_NODE_DEPTH} (a node that is its own ancestor?)",
                node.index()
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        if !local.is_finite() {
            return Err(format!("node {}: transform is not finite", node.index()));
        }
        let m = parent * local;
        if node.skin().is_some() {
            self.ignored.insert("gltf_skins".into());
        }
        if node.camera().is_some() {
            self.ignored.insert("gltf_cameras".into());
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let at = format!("mesh {} primitive {}", mesh.index(), prim.index());
                self.primitive(&prim, &m)
                    .map_err(|e| format!("{at}: {e}"))?;
            }
        }
        for child in node.children() {
            self.node(&child, m, depth + 1)?;
        }
        Ok(())
    }

    fn primitive(&mut self, prim: &gltf::Primitive, m: &DMat4) -> Result<(), String> {
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.ignored.insert("gltf_points_lines".into());
            return Ok(());
        }
        if prim.morph_targets().len() > 0 {
            self.ignored.insert("gltf_morph_targets".into());
        }
        if prim.get(&gltf::Semantic::Normals).is_some() {
            self.ignored.insert("gltf_vertex_normals".into());
        }
        if prim.get(&gltf::Semantic::Colors(0)).is_some() {
            self.ignored.insert("gltf_vertex_colors".into());
        }
        let reader = prim.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<DVec3> = reader
            .read_positions()
            .ok_or("has no readable POSITION attribute")?
            .map(|p| DVec3::from_array(p.map(f64::from)))
            .collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {i} is not finite"));
        }
        let expected = prim
            .get(&gltf::Semantic::Positions)
            .map_or(0, |a| a.count());
        if positions.len() != expected {
            return Err(format!(
                "POSITION holds {} of its {expected} vertices (buffer too short)",
                positions.len()
            ));
        }
        let indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => {
                let v: Vec<u32> = ix.into_u32().collect();
                let count = prim.indices().map_or(0, |a| a.count());
                if v.len() != count {
                    return Err(format!(
                        "indices hold {} of their {count} entries (buffer too short)",
                        v.len()
                    ));
                }
                v
            }
            None if prim.indices().is_some() => return Err("indices cannot be read".into()),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(format!(
                "index {bad} is out of range ({} vertices)",
                positions.len()
            ));
        }
        let p = |i: u32| m.transform_point3(positions[i as usize]);
        // A mirroring node transform reverses the winding; glTF keeps the front face.
        let mirrored = m.determinant() < 0.0;
        let triangles = triangulate(mode, &indices)
            .map(|[a, b, c]| {
                if mirrored {
                    [p(a), p(c), p(b)]
                } else {
                    [p(a), p(b), p(c)]
                }
            })
            .collect();
        self.parts.push(GltfPart {
            material: prim.material().index().unwrap_or(self.default_material),
            triangles,
        });
        Ok(())
    }
}

/// The triangles of a triangle list, strip or fan, as glTF 2.0 defines their vertex order
/// (§3.7.2.1: strip triangle i is (i, i+1+i%2, i+2−i%2); fan triangle i is (i+1, i+2, 0)).
fn triangulate(mode: Mode, ix: &[u32]) -> Box<dyn Iterator<Item = [u32; 3]> + '_> {
    match mode {
        Mode::TriangleStrip => Box::new(
            (0..ix.len().saturating_sub(2))
                .map(move |i| [ix[i], ix[i + 1 + i % 2], ix[i + 2 - i % 2]]),
        ),
        Mode::TriangleFan => {
            Box::new((0..ix.len().saturating_sub(2)).map(move |i| [ix[i + 1], ix[i + 2], ix[0]]))
        }
        _ => Box::new(ix.chunks_exact(3).map(|t| [t[0], t[1], t[2]])),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding_of_their_first_triangle() {
        let ix = [0, 1, 2, 3, 4];
        let strip: Vec<_> = triangulate(Mode::TriangleStrip, &ix).collect();
        assert_eq!(strip, vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
        let fan: Vec<_> = triangulate(Mode::TriangleFan, &ix).collect();
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]);
        let list: Vec<_> = triangulate(Mode::Triangles, &ix).collect();
        assert_eq!(list, vec![[0, 1, 2]]);
        assert_eq!(triangulate(Mode::TriangleFan, &ix[..2]).count(), 0);
    }
}
