//! The `raysched` binary: the command line lives in [`app`], on this side of the library.

mod app;

fn main() -> std::process::ExitCode {
    app::main()
}
