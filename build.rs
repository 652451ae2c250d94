//! Build script: fixes the build's provenance at compile time (see `build/provenance.rs`).

#[path = "build/provenance.rs"]
mod provenance;

fn main() {
    provenance::emit();
}
