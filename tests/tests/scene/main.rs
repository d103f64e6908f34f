//! End-to-end tests: USD (or Alembic) in, pixels out, one integration-test binary with a module per
//! area. Test names carry the module path, so `cargo test -p scene-tests textures::` runs one area.
//!
//! - [`accel`]: the BVH on the ingested tractor against brute force and the scalar kernels;
//! - [`pipeline`]: analytic scenes (Lambert under a dome and a distant light, the white furnace),
//!   determinism, bad input, wavefront against scalar;
//! - [`textures`]: texture files and UsdShade networks through ingest and render;
//! - [`dome`]: textured dome lights;
//! - [`instancing`]: two-level instancing against the flattened scene;
//! - [`alembic`]: Alembic archives against the USD they were exported from;
//! - [`materialx`]: a MaterialX look (`.mtlx` referenced from USD) through ingest and render.

mod accel;
mod alembic;
mod dome;
mod instancing;
mod materialx;
mod pipeline;
mod textures;
