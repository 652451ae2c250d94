//! The `embree4` tracer keeps the Embree contract of `embree_contract` (agreement with `brute` and
//! `bvh`, the `t` interval, images, robustness), builds with its options and reports Embree's
//! errors as `Err`. Without the feature, asking for it is a clear error. Run with
//! `cargo test --features embree4`.

#[cfg(not(feature = "embree4"))]
#[test]
fn embree4_without_the_feature_is_an_error_naming_it() {
    use raysched::tracer::{AnyTracer, TracerError, TracerKind};
    let scene = raysched::scene::load_scene(
        std::path::Path::new("scenes/simple.toml"),
        &Default::default(),
    )
    .unwrap();
    for kind in [TracerKind::Embree4, TracerKind::Embree4Robust] {
        let err = AnyTracer::build(kind, &scene, 1).err().expect("must fail");
        assert!(matches!(&err, TracerError::FeatureOff { feature, .. } if feature == "embree4"));
        assert!(err.to_string().contains("--features embree4"), "{err}");
        assert!(kind.available().is_err());
    }
}

#[cfg(feature = "embree4")]
mod with_embree4 {
    use crate::embree_contract::{random_geometry, Backend};
    use raysched::tracer::embree::v4::{Embree4Options, Embree4Tracer};
    use raysched::tracer::{Tracer, TracerKind};

    fn embree4(g: &raysched::scene::Geometry, robust: bool) -> Embree4Tracer {
        Embree4Tracer::with_options(g, Embree4Options { threads: 1, robust }).unwrap()
    }

    const BACKEND: Backend = Backend {
        kinds: [TracerKind::Embree4, TracerKind::Embree4Robust],
        build: |g, robust| Box::new(embree4(g, robust)),
    };

    crate::embree_contract::contract_tests!(BACKEND);

    #[test]
    fn ids_options_version_and_errors_through_the_callback() {
        let g = random_geometry(4, 10, 2);
        assert_eq!(embree4(&g, false).id(), "embree4");
        assert_eq!(embree4(&g, true).id(), "embree4_robust");
        let opts = Embree4Options {
            threads: 2,
            robust: false,
        };
        let e = Embree4Tracer::with_options(&g, opts).unwrap();
        assert_eq!(e.options(), opts);
        assert_eq!(e.version() / 10_000, 4, "{}", e.version());
        assert!(e.os_threads_after_build.is_some_and(|n| n >= 1));
        let err = Embree4Tracer::with_options(&g, Embree4Options { threads: 0, ..opts })
            .err()
            .unwrap();
        assert!(err.0.contains("threads"), "{err}");
        // A configuration Embree rejects: its error callback's message becomes the `Err`.
        let err = Embree4Tracer::with_device_config(&g, "threads=1,verbose=x", opts)
            .err()
            .expect("bad config");
        assert!(err.0.contains("Embree error"), "{err}");
    }
}
