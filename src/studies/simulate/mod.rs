//! Simulating schedulers beyond this machine: the measured inputs ([`inputs`]), the
//! experiment file ([`config`]), the sweep ([`sweep`]), the validation against measured runs
//! ([`validate`]) and the plots ([`plot`]). The simulations themselves run SimGrid
//! ([`crate::studies::simulate::simgrid`], feature `simgrid`) in a child process each ([`child`]); this module
//! builds without the feature.

pub mod auto_judge;
pub mod child;
pub mod config;
pub mod error;
pub mod hetero;
pub mod inputs;
pub mod job;
pub mod plot;
pub mod rows;
#[cfg(feature = "simgrid")]
pub mod simgrid;
pub mod sweep;
pub mod validate;
