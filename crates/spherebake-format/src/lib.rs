//! The `.sphb` binary format, version 1: byte layout, validating reader and deterministic writer.
//!
//! A `.sphb` file stores a bounding *sphere set* of a mesh (model space, in the units named by
//! the metadata: metres for glTF input) plus the optional data a bake produced: a sphere
//! hierarchy, surface sample points per sphere, albedo spherical harmonics per sphere
//! (linear RGB, real orthonormal SH with the Condon–Shortley phase, index `i = l(l+1) + m`),
//! per-sphere skinning terms, a bone table and metadata.
//! The normative description, with byte tables and numbered validation rules, is
//! `formats/spherebake-v1.md` in the repository; this crate follows it.
//!
//! # Layout in brief
//!
//! Little-endian throughout. A 64-byte header (magic, version major.minor, section count,
//! section table offset, file size, CRC-32s), a section table of 32-byte entries (kind,
//! offset, length, CRC-32), then the sections, each starting at a multiple of 16 bytes,
//! zero-padded. Unknown section kinds are skipped; sections a bake did not produce are absent.
//!
//! # Use
//!
//! ```
//! use spherebake_format::{read, write, Sphere, SphbFile};
//!
//! let file = SphbFile {
//!     spheres: vec![Sphere { center: [0.0, 1.0, 0.0], radius: 0.5 }],
//!     ..SphbFile::default()
//! };
//! let bytes = write(&file);
//! let back = read(&bytes).expect("a file we just wrote is valid");
//! assert_eq!(back, file);
//! assert_eq!(write(&back), bytes); // deterministic
//! ```
//!
//! Errors carry a stable rule ID ([`Rule::id`]), grouped by section: 1xxx header,
//! 2xxx section table, 3xxx spheres, 4xxx hierarchy, 5xxx samples, 6xxx albedo SH, 7xxx skin,
//! 8xxx bones, 9xxx metadata.
//!
//! # Architecture invariant
//!
//! `no_std` + `alloc`; the dependencies are `crc32fast` (no default features) and `libm` (the
//! square root of the octahedral normal decoding).
//! No Rust-only encoding: every byte is defined by the specification so that C or C++ can read it.
//! The reader never panics and never reads out of bounds, for any byte string.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

extern crate alloc;

mod error;
mod model;
pub mod quant;
mod read;
mod write;

pub use error::{Detail, Rule, SectionKind, ValidationError};
pub use model::{
    AlbedoSh, BoneRecord, ColourSpace, Hierarchy, HierarchyNode, Metadata, NodeLists, SamplePoint, Samples, ShBasis,
    SkinEntry, SkinTerms, SphbFile, Sphere, DIRECTION_COUNT, MAX_BONES_PER_SPHERE, MAX_SH_ORDER, NO_PARENT,
    UNUSED_BONE,
};
pub use read::{read, read_header_and_table, repair_checksums, Header, SectionEntry};
pub use write::{write, write_compact, EncodeError};

/// The 8 magic bytes at offset 0: `89 'S' 'P' 'H' 'B' 0D 0A 1A` (PNG-style: catches text-mode
/// transfers and 7-bit channels).
pub const MAGIC: [u8; 8] = [0x89, b'S', b'P', b'H', b'B', 0x0D, 0x0A, 0x1A];

/// Major format version this crate reads and writes; other majors are refused.
pub const FORMAT_MAJOR: u16 = 1;

/// Newest minor format version this crate knows (1: the compact sections `samples_q16` and
/// `albedo_sh_f16`; 2: the `sample_areas` section); every minor of [`FORMAT_MAJOR`] is
/// accepted. Writers stamp the lowest minor whose sections they use: [`write`] writes minor 0
/// (2 with sample areas), [`write_compact`] minor 1 (2 with sample areas).
pub const FORMAT_MINOR: u16 = 2;

/// Size of the v1.0 header in bytes.
pub const HEADER_SIZE: usize = 64;

/// Size of one section table entry in bytes.
pub const SECTION_ENTRY_SIZE: usize = 32;

/// Alignment of the section table, of every section and of the file size, in bytes.
pub const ALIGN: usize = 16;

/// The header CRC-32 covers header bytes `0..HEADER_CRC_RANGE_END` (everything before the CRC itself).
pub const HEADER_CRC_RANGE_END: usize = 44;
