//! Does nothing: it exists so that the build-dependency `syn` (features only, see Cargo.toml) is
//! part of the host build, giving the derive macros the workspace's features.
fn main() {}
