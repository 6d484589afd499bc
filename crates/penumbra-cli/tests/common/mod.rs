//! Helpers shared by the command line's integration tests: the library's
//! (devices, data, assets, temporary folders) and running the binary.
#![allow(dead_code, unused_imports)]

#[path = "../../../penumbra/tests/common/mod.rs"]
mod library;

pub use library::*;

pub mod cli;
