//! Geometry for spherebake: the canonical mesh type, topology analysis, and (in later modules)
//! BVH ray casts, voxelization, exact sphere ∩ mesh volumes and mean value coordinates.
//!
//! Architecture invariant: this crate does no IO and sees no paths. Slices and settings in,
//! values plus warnings out.
//!
//! Conventions: right-handed, positions in model (scene) space in the input's own units
//! (glTF: metres), colours in linear RGB unless a name says `srgb`.

pub mod anim;
mod bucket;
pub mod bvh;
pub mod disjoint;
pub mod edges;
pub mod fold_hash;
pub mod mesh;
pub mod motion;
pub mod mvc;
pub mod normals;
pub mod orient;
pub mod rng;
pub mod sphere;
pub mod texels;
pub mod topology;
pub mod triangle;
pub mod volume;
pub mod voxel;
pub mod winding;

pub use glam;
pub use mesh::*;
pub use topology::TopologyReport;
