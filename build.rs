//! Build script. Each concern lives in its own file under `build/`, included here as a module:
//! the build's provenance fixed at compile time, and where Embree 4 is found.

#[path = "build/embree4.rs"]
mod embree4;
#[path = "build/provenance.rs"]
mod provenance;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    provenance::emit();
    embree4::main();
}
