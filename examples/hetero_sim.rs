//! The simulated H200 pair (`raysched::simulate::hetero`): 16 CPU threads and one GPU at the
//! rates measured in `results/published/gpu/`, Cornell 1024² at 512 spp, under the default
//! balancer and under the hand-out settings measured there, each against the summed rate.
//!
//! `cargo run --release --example hetero_sim`

use raysched::simulate::hetero::{simulate, Handing, Platform};

fn main() {
    let p = Platform::h200_cornell();
    let runs = [
        (
            "default: balancer, 16², B = 2",
            16,
            Handing::Balanced { buffer: 2 },
        ),
        ("balancer, 32², B = 4", 32, Handing::Balanced { buffer: 4 }),
        ("balancer, 8², B = 2", 8, Handing::Balanced { buffer: 2 }),
        (
            "old one grain: 32², B = 4, gpu B = 256",
            32,
            Handing::Fixed {
                buffer: 4,
                gpu_grain: 0,
                gpu_buffer: 256,
            },
        ),
        (
            "own grains by hand: 8², B = 2, gpu 512² × 2",
            8,
            Handing::Fixed {
                buffer: 2,
                gpu_grain: 512 * 512,
                gpu_buffer: 2,
            },
        ),
    ];
    for (name, chunk, handing) in runs {
        println!("{name}: {:?}", simulate(&p, chunk, handing));
    }
}
