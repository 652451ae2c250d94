//! The `embree` tracer keeps the Embree contract of `embree_contract` (agreement with `brute` and
//! `bvh`, the `t` interval, images, robustness), builds with its options and reports Embree's
//! errors as `Err`. Without the feature, asking for it is a clear error. Run with
//! `cargo test --features embree`.

#[cfg(not(feature = "embree"))]
#[test]
fn embree_without_the_feature_is_an_error_naming_it() {
    use raysched::tracer::{AnyTracer, TracerError, TracerKind};
    let scene = raysched::scene::load_scene(
        std::path::Path::new("scenes/simple.toml"),
        &Default::default(),
    )
    .unwrap();
    for kind in [TracerKind::Embree, TracerKind::EmbreeRobust] {
        let err = AnyTracer::build(kind, &scene, 1).err().expect("must fail");
        assert!(matches!(&err, TracerError::FeatureOff { feature, .. } if feature == "embree"));
        assert!(err.to_string().contains("--features embree"), "{err}");
        assert!(kind.available().is_err());
    }
}

#[cfg(feature = "embree")]
mod with_embree {
    use crate::embree_contract::{random_geometry, Backend};
    use raysched::tracer::embree::v3::{EmbreeOptions, EmbreeTracer};
    use raysched::tracer::{Tracer, TracerKind};

    fn embree(g: &raysched::scene::Geometry, robust: bool) -> EmbreeTracer {
        EmbreeTracer::with_options(g, EmbreeOptions { threads: 1, robust }).unwrap()
    }

    const BACKEND: Backend = Backend {
        kinds: [TracerKind::Embree, TracerKind::EmbreeRobust],
        build: |g, robust| Box::new(embree(g, robust)),
    };

    crate::embree_contract::contract_tests!(BACKEND);

    #[test]
    fn ids_options_and_bad_input() {
        let g = random_geometry(4, 10, 2);
        assert_eq!(embree(&g, false).id(), "embree");
        assert_eq!(embree(&g, true).id(), "embree_robust");
        assert!(embree(&g, true).options().robust);
        let e = EmbreeTracer::new(&g, 2).unwrap();
        assert_eq!(
            e.options(),
            EmbreeOptions {
                threads: 2,
                robust: false
            }
        );
        assert!(e.os_threads_after_build.is_some_and(|n| n >= 1));
        let err = EmbreeTracer::new(&g, 0).err().unwrap();
        assert!(err.0.contains("threads"), "{err}");
        // Embree's error callback becomes a Rust error, no panic.
        let opts = EmbreeOptions {
            threads: 1,
            robust: false,
        };
        let err = EmbreeTracer::with_device_config(&g, "threads=1,verbose=x", opts)
            .err()
            .expect("bad config");
        assert!(err.0.contains("Embree"), "{err}");
    }
}
