//! The scenes penumbra ships under `assets/`, made in code: what `penumbra
//! gen-assets` writes, byte for byte (the committed files are its output),
//! and what the library's tests and benches render.
//!
//! - [`raytrace`]: the ray tracer's scenes (`assets/raytrace/`): mirror,
//!   glass and Phong spheres over a checkerboard, a Cornell box, and extreme
//!   cases, each with its camera;
//! - [`chess`]: the chess-like scene of several moving objects
//!   (`assets/chess/`, `assets/scenes/chess.json`);
//! - [`animations`]: example animations in the forms users bring
//!   (`assets/animations/`: an OBJ sequence, skinned and morphed glTF).
//!
//! The library's procedural meshes with closed-form answers
//! (`penumbra::scene::procedural`) stay in the library: its doc examples and
//! tests are built on them.
//!
//! A crate of its own so that the library carries no asset content and the
//! library's tests can still render these scenes (a dev-dependency).

#![warn(missing_docs)]

pub mod animations;
pub mod chess;
pub mod raytrace;
