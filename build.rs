//! Build script. Each concern lives in its own file under `build/`, included here as a module.

#[path = "build/embree4.rs"]
mod embree4;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    embree4::main();
}
