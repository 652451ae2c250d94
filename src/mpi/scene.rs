//! Shipping a scene to ranks that share no filesystem with rank 0: the scene text, the
//! overrides and every mesh file's bytes go out in one broadcast; each rank rebuilds the scene
//! and checks its hash against rank 0's.

use super::wire::ScenePackage;
use crate::core::scene::format::ShapeSpec;
use crate::core::scene::{load_scene_str, Scene, SceneError, SceneFile, SceneOverrides};
use std::path::{Component, Path, PathBuf};

/// Why a scene could not be packaged on rank 0 or rebuilt on another rank.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// A file that cannot be read or shipped, or a rebuilt scene that differs, in one message
    /// naming it.
    #[error("{0}")]
    Refused(String),
    /// The scene loader refused the scene, naming its field.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The scene text is no scene file.
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    /// Writing a mesh under the rank's temporary folder.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Read the scene file and its meshes on rank 0 and load the scene; the package carries
/// what every other rank needs to load the same scene.
pub fn package(
    path: &Path,
    overrides: &SceneOverrides,
    tracer: &str,
) -> Result<(Scene, ScenePackage), PackError> {
    let display = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| PackError::Refused(format!("{display}: cannot read scene file: {e}")))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    // Load first: a bad scene is reported by the loader, naming its field.
    let scene = load_scene_str(&text, &display, &base, &name, overrides)?;
    let file: SceneFile = toml::from_str(&text)?;
    let mut meshes = Vec::new();
    for (i, shape) in file.shapes.iter().enumerate() {
        let Some(rel) = shape.path() else {
            continue;
        };
        if Path::new(rel).is_absolute() {
            return Err(PackError::Refused(format!(
                "{display}: shapes[{i}].path: '{rel}' is absolute; MPI ranks get meshes by path relative to the scene file"
            )));
        }
        let mut files = vec![rel.to_string()];
        if let ShapeSpec::Gltf { .. } = shape {
            // A .gltf's buffers travel too, at their place beside it.
            let dir = Path::new(rel).parent().unwrap_or(Path::new(""));
            let uris =
                crate::core::scene::gltf::external_buffers(&base.join(rel)).map_err(|e| {
                    PackError::Refused(format!("{display}: shapes[{i}].path: '{rel}': {e}"))
                })?;
            files.extend(
                uris.iter()
                    .map(|u| dir.join(u).to_string_lossy().into_owned()),
            );
        }
        for f in files {
            let bytes = std::fs::read(base.join(&f)).map_err(|e| {
                PackError::Refused(format!(
                    "{display}: shapes[{i}].path: cannot read '{f}': {e}"
                ))
            })?;
            meshes.push((f, bytes));
        }
    }
    let pkg = ScenePackage {
        text,
        display,
        name,
        overrides: overrides.clone(),
        meshes,
        tracer: tracer.to_string(),
        hash: scene.hash,
    };
    Ok((scene, pkg))
}

/// Rebuild the scene of `pkg` on this rank: meshes are written under a private temporary
/// folder (deep enough for `../` paths), loaded, and the folder removed again.
pub fn unpack(pkg: &ScenePackage, rank: i32) -> Result<Scene, PackError> {
    let ups = pkg
        .meshes
        .iter()
        .map(|(p, _)| {
            Path::new(p)
                .components()
                .filter(|c| *c == Component::ParentDir)
                .count()
        })
        .max()
        .unwrap_or(0);
    let root = std::env::temp_dir().join(format!("raysched-mpi-{}-rank{rank}", std::process::id()));
    let mut base = root.clone();
    for _ in 0..ups {
        base.push("d");
    }
    let result = (|| {
        for (rel, bytes) in &pkg.meshes {
            let full: PathBuf = base.join(rel);
            if !normalise(&full).starts_with(&root) {
                return Err(PackError::Refused(format!(
                    "mesh path '{rel}' leaves the scene folder"
                )));
            }
            if let Some(dir) = full.parent() {
                std::fs::create_dir_all(dir)?;
            }
            std::fs::write(&full, bytes)?;
        }
        std::fs::create_dir_all(&base)?;
        let scene = load_scene_str(&pkg.text, &pkg.display, &base, &pkg.name, &pkg.overrides)?;
        if scene.hash != pkg.hash {
            return Err(PackError::Refused(format!(
                "scene hash {:016x} differs from rank 0's {:016x}: the ranks would render different scenes",
                scene.hash,
                pkg.hash
            )));
        }
        Ok(scene)
    })();
    let _ = std::fs::remove_dir_all(&root);
    result
}

/// `a/b/../c` → `a/c`, without touching the filesystem.
fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_packaged_scene_unpacks_to_the_same_hash_and_a_changed_one_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("s")).unwrap();
        std::fs::write(
            dir.path().join("tri.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let text = r#"
[camera]
origin = [0, 0, 4]
target = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 40
width = 4
height = 4
[materials.white]
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]
[[shapes]]
type = "mesh"
path = "../tri.obj"
material = "white"
[[lights]]
type = "environment"
radiance = [1, 1, 1]
"#;
        let path = dir.path().join("s/scene.toml");
        std::fs::write(&path, text).unwrap();
        let (scene, pkg) = package(&path, &SceneOverrides::default(), "bvh").unwrap();
        assert_eq!(pkg.meshes.len(), 1);
        let back = unpack(&pkg, 1).unwrap();
        assert_eq!(back.hash, scene.hash);
        assert_eq!(
            back.geometry.triangles.len(),
            scene.geometry.triangles.len()
        );
        let mut bad = pkg.clone();
        bad.meshes[0].1 = b"v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
        assert!(unpack(&bad, 1)
            .unwrap_err()
            .to_string()
            .contains("differs from rank 0"));
    }
}
