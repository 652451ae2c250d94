use std::process::ExitCode;

fn main() -> ExitCode {
    raysched::cli::main()
}
