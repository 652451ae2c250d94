//! Finds Embree 4 for the `embree4` feature (nothing happens without it). In order of preference:
//!
//! 1. the system's Embree 4: `pkg-config embree4`, else `libembree4.so` in a known library folder;
//! 2. `EMBREE4_DIR`, a folder holding `libembree4.so*` itself or in `lib/` or `lib64/`;
//! 3. `.deps/embree4/lib`, where `.ci/fetch-embree4` unpacks PyPI's `embreex` wheel.
//!
//! `embree4-sys` links `-lembree4`. Where the folder has no `libembree4.so` (a runtime-only
//! install, or the wheel's `libembree4-<hash>.so.4`), a `libembree4.so` symlink to the library is
//! made in `OUT_DIR` and put on the link path. The library's folder goes into the rpath of every
//! binary, test and example, so they run without `LD_LIBRARY_PATH`.

use std::path::{Path, PathBuf};
use std::process::Command;

const KNOWN_DIRS: [&str; 5] = [
    "/usr/lib/x86_64-linux-gnu",
    "/usr/lib64",
    "/usr/lib",
    "/usr/local/lib",
    "/usr/local/lib64",
];

pub(crate) fn main() {
    println!("cargo:rerun-if-changed=build/embree4.rs");
    println!("cargo:rerun-if-env-changed=EMBREE4_DIR");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
    if std::env::var_os("CARGO_FEATURE_EMBREE4").is_none() {
        return;
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let fetched = manifest.join(".deps/embree4/lib");
    println!("cargo:rerun-if-changed={}", fetched.display());

    let from_user = std::env::var_os("EMBREE4_DIR").map(PathBuf::from);
    let found = system_dir()
        .map(|d| ("system", d))
        .or_else(|| match &from_user {
            Some(dir) => Some(("EMBREE4_DIR", user_dir(dir))),
            None => None,
        })
        .or_else(|| library_in(&fetched).map(|_| ("fetched embreex wheel", fetched.clone())));
    let Some((origin, dir)) = found else {
        fail();
    };
    let Some(lib) = library_in(&dir) else {
        fail_at(origin, &dir);
    };
    let link_dir = if lib.file_name().is_some_and(|n| n == "libembree4.so") {
        dir.clone()
    } else {
        let out =
            PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets it")).join("embree4");
        std::fs::create_dir_all(&out).expect("create OUT_DIR/embree4");
        let link = out.join("libembree4.so");
        let _ = std::fs::remove_file(&link);
        symlink(&lib, &link);
        out
    };
    println!("cargo:rustc-link-search=native={}", link_dir.display());
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
    println!("cargo:rustc-env=RAYSCHED_EMBREE4_LIB={}", lib.display());
}

/// `pkg-config embree4`'s library folder, else a known folder with `libembree4.so`.
fn system_dir() -> Option<PathBuf> {
    let from_pkg_config = Command::new("pkg-config")
        .args(["--variable=libdir", "embree4"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()))
        .filter(|d| library_in(d).is_some());
    from_pkg_config.or_else(|| {
        KNOWN_DIRS
            .iter()
            .map(PathBuf::from)
            .find(|d| d.join("libembree4.so").exists())
    })
}

/// The folder of `EMBREE4_DIR` that holds the library: itself, `lib/` or `lib64/`.
fn user_dir(dir: &Path) -> PathBuf {
    [dir.to_path_buf(), dir.join("lib"), dir.join("lib64")]
        .into_iter()
        .find(|d| library_in(d).is_some())
        .unwrap_or_else(|| dir.to_path_buf())
}

/// The Embree 4 library in `dir`: `libembree4.so`, else `libembree4.so.4*`, else the wheel's
/// `libembree4-<hash>.so.4`.
fn library_in(dir: &Path) -> Option<PathBuf> {
    let plain = dir.join("libembree4.so");
    if plain.exists() {
        return Some(plain);
    }
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                n.starts_with("libembree4.so.4")
                    || (n.starts_with("libembree4-") && n.contains(".so.4"))
            })
        })
        .collect();
    names.sort();
    names.into_iter().next()
}

#[cfg(unix)]
fn symlink(target: &Path, link: &Path) {
    if let Err(e) = std::os::unix::fs::symlink(target, link) {
        eprintln!(
            "embree4: cannot link {} -> {}: {e}",
            link.display(),
            target.display()
        );
        std::process::exit(1);
    }
}

#[cfg(not(unix))]
fn symlink(target: &Path, link: &Path) {
    if let Err(e) = std::fs::copy(target, link) {
        eprintln!(
            "embree4: cannot copy {} to {}: {e}",
            target.display(),
            link.display()
        );
        std::process::exit(1);
    }
}

const OPTIONS: &str = "feature `embree4` needs Embree 4; provide one of: \
    (1) a system Embree 4 (pkg-config `embree4`, or libembree4.so in /usr/lib or /usr/local/lib), \
    (2) EMBREE4_DIR=<folder with libembree4.so* or its lib/>, \
    (3) `bash .ci/fetch-embree4` (PyPI's embreex wheel into .deps/embree4)";

fn fail() -> ! {
    eprintln!("error: {OPTIONS}");
    std::process::exit(1);
}

fn fail_at(origin: &str, dir: &Path) -> ! {
    eprintln!(
        "error: {origin}: no libembree4.so* in {}; {OPTIONS}",
        dir.display()
    );
    std::process::exit(1);
}
