//! Provenance fixed at build time, read back by `raysched::provenance` through `env!`: the
//! commit (and whether the tree had local changes), rustc, the target's CPU features, the cargo
//! features and the profile. Read here rather than at run time, so a binary run from another
//! folder (or with another rustc on PATH) still says what it is.

use std::path::{Path, PathBuf};
use std::process::Command;

fn cmd(program: &str, args: &[&str], dir: &Path) -> Option<String> {
    let out = Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn set(key: &str, value: &str) {
    println!("cargo:rustc-env={key}={value}");
}

/// The paths whose content the binary is built from.
const BUILT_FROM: [&str; 6] = [
    "src",
    "build",
    "build.rs",
    "Cargo.toml",
    "Cargo.lock",
    "assets",
];

/// FNV-1a, 16 hex digits: a short fingerprint of the uncommitted changes.
fn fnv_hex(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Emit every `RAYSCHED_BUILD_*` variable and the rerun triggers.
pub(crate) fn emit() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".into()));
    let commit = cmd("git", &["rev-parse", "HEAD"], &root).unwrap_or_else(|| "unknown".into());
    // Only what goes into the binary: an edited test or README does not make a build dirty.
    let mut args = vec!["diff", "HEAD", "--no-ext-diff", "--"];
    args.extend(BUILT_FROM);
    let mut diff = cmd("git", &args, &root).unwrap_or_default();
    let mut untracked = vec!["ls-files", "--others", "--exclude-standard", "--"];
    untracked.extend(BUILT_FROM);
    diff += &cmd("git", &untracked, &root).unwrap_or_default();
    let dirty = !diff.is_empty();
    set("RAYSCHED_BUILD_COMMIT", &commit);
    set("RAYSCHED_BUILD_DIRTY", if dirty { "true" } else { "false" });
    set(
        "RAYSCHED_BUILD_DIFF",
        &if dirty {
            fnv_hex(diff.as_bytes())
        } else {
            String::new()
        },
    );
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let rustc_v = cmd(&rustc, &["-V"], &root).unwrap_or_else(|| "unknown".into());
    set("RAYSCHED_BUILD_RUSTC", &rustc_v);
    set(
        "RAYSCHED_BUILD_TARGET",
        &std::env::var("TARGET").unwrap_or_default(),
    );
    set(
        "RAYSCHED_BUILD_CPU_FEATURES",
        &std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default(),
    );
    let mut features: Vec<String> = std::env::vars()
        .filter_map(|(k, _)| k.strip_prefix("CARGO_FEATURE_").map(|f| f.to_lowercase()))
        .filter(|f| f != "default")
        .collect();
    features.sort();
    set("RAYSCHED_BUILD_FEATURES", &features.join(","));
    // PROFILE is `release` or `debug` (cargo's name for dev, test and bench builds alike);
    // OPT_LEVEL tells a `--release` build from an optimised test build.
    set(
        "RAYSCHED_BUILD_PROFILE",
        &std::env::var("PROFILE").unwrap_or_default(),
    );
    set(
        "RAYSCHED_BUILD_OPT_LEVEL",
        &std::env::var("OPT_LEVEL").unwrap_or_default(),
    );
    // Rerun when the commit or the tracked sources change (the dirty flag and diff follow).
    if let Some(git_dir) = cmd("git", &["rev-parse", "--absolute-git-dir"], &root) {
        let git_dir = PathBuf::from(git_dir);
        println!("cargo:rerun-if-changed={}", git_dir.join("HEAD").display());
        println!("cargo:rerun-if-changed={}", git_dir.join("index").display());
        if let Some(common) = cmd("git", &["rev-parse", "--git-common-dir"], &root) {
            let common = root.join(common);
            println!(
                "cargo:rerun-if-changed={}",
                common.join("refs/heads").display()
            );
            println!(
                "cargo:rerun-if-changed={}",
                common.join("packed-refs").display()
            );
        }
    }
    for p in BUILT_FROM {
        println!("cargo:rerun-if-changed={}", root.join(p).display());
    }
    println!("cargo:rerun-if-env-changed=RUSTC");
}
