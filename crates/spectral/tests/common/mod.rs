// Shared helpers of the integration tests.
#![allow(dead_code)]
/// The crate-private double-double arithmetic, compiled into the test crate from its source.
#[path = "../../src/dd.rs"]
pub mod dd;
pub mod dd_ext;
pub mod fixtures;
