//! Embree 3 thread control, in its own test binary so no other test creates threads or
//! devices meanwhile.
#![cfg(feature = "embree")]

#[path = "common/embree_threads.rs"]
mod common;

use raysched::tracer::{AnyTracer, TracerKind};

#[test]
fn embree_devices_and_os_threads_are_what_the_run_asked_for() {
    common::devices_and_os_threads_are_what_the_run_asked_for(
        TracerKind::Embree,
        raysched::tracer::embree::v3::devices_created,
        |t| match t {
            AnyTracer::Embree(inner) => inner.os_threads_after_build,
            _ => panic!("not embree"),
        },
    );
}
