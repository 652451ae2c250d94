//! Embree 4 thread control, in its own test binary so no other test creates threads or
//! devices meanwhile.
#![cfg(feature = "embree4")]

#[path = "common/embree_threads.rs"]
mod common;

use raysched::tracer::{AnyTracer, TracerKind};

#[test]
fn embree4_devices_and_os_threads_are_what_the_run_asked_for() {
    common::devices_and_os_threads_are_what_the_run_asked_for(
        TracerKind::Embree4,
        raysched::tracer::embree::v4::devices_created,
        |t| match t {
            AnyTracer::Embree4(inner) => inner.os_threads_after_build,
            _ => panic!("not embree4"),
        },
    );
}
