//! `auto` against the best fixed configuration on the corpus of an `auto_verdict` experiment,
//! without the command line: what `raysched simulate experiments/auto.toml` runs.
//!
//! `cargo run --release --example auto_verdict -- experiments/auto.toml OUT_DIR`

use raysched::simulate::auto_judge;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [plan, out] = args.as_slice() else {
        return Err("usage: auto_verdict EXPERIMENT.toml OUT_DIR".into());
    };
    let (plan, maps) = auto_judge::load(&PathBuf::from(plan))?;
    let w = auto_judge::run(&plan, &maps, &PathBuf::from(out), true)?;
    println!("{}", w.summary);
    for l in &w.worst {
        println!("{l}");
    }
    Ok(())
}
