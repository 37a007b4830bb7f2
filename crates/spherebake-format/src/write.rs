//! The writer: deterministic little-endian bytes with zero padding.

use alloc::vec::Vec;

use crate::model::{AlbedoSh, BoneRecord, Hierarchy, Metadata, Samples, SkinTerms, SphbFile, Sphere, NO_PARENT};
use crate::quant::{f16_from_f32, oct_encode, SampleBox};
use crate::{SectionKind, ALIGN, FORMAT_MAJOR, HEADER_SIZE, MAGIC, SECTION_ENTRY_SIZE};

/// Saturating conversion of a length to the u32 stored in the file.
///
/// Only data beyond 4 GiB saturates, which the reader then rejects by a length rule.
fn len_u32(len: usize) -> u32 {
    u32::try_from(len).unwrap_or(u32::MAX)
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f32s(out: &mut Vec<u8>, vs: &[f32]) {
    for &v in vs {
        put_f32(out, v);
    }
}

fn pad_to_align(out: &mut Vec<u8>) {
    while out.len() % ALIGN != 0 {
        out.push(0);
    }
}

fn spheres_section(spheres: &[Sphere]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + 16 * spheres.len());
    put_u32(&mut out, len_u32(spheres.len()));
    out.extend_from_slice(&[0; 12]);
    for s in spheres {
        put_f32s(&mut out, &s.center);
        put_f32(&mut out, s.radius);
    }
    out
}

fn hierarchy_section(h: &Hierarchy) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + 32 * h.nodes.len() + 4 * (h.children.len() + h.leaves.len()));
    put_u32(&mut out, len_u32(h.nodes.len()));
    put_u32(&mut out, h.root);
    put_u32(&mut out, len_u32(h.children.len()));
    put_u32(&mut out, len_u32(h.leaves.len()));
    for n in &h.nodes {
        put_f32s(&mut out, &n.center);
        put_f32(&mut out, n.radius);
        put_u32(&mut out, n.first_child);
        put_u32(&mut out, n.child_count);
        put_u32(&mut out, n.first_leaf);
        put_u32(&mut out, n.leaf_count);
    }
    for &c in h.children.iter().chain(&h.leaves) {
        put_u32(&mut out, c);
    }
    out
}

fn samples_section(s: &Samples) -> Vec<u8> {
    let mut out = Vec::with_capacity(32 + 4 * s.offsets.len() + 32 * s.points.len());
    put_u32(&mut out, len_u32(s.sphere_count()));
    put_u32(&mut out, len_u32(s.total()));
    out.extend_from_slice(&[0; 8]);
    if s.offsets.is_empty() {
        put_u32(&mut out, 0);
    }
    for &o in &s.offsets {
        put_u32(&mut out, o);
    }
    pad_to_align(&mut out);
    for p in &s.points {
        put_f32s(&mut out, &p.position);
        put_f32s(&mut out, &p.normal);
        out.push(p.direction);
        out.push(p.rule);
        out.extend_from_slice(&[0; 6]);
    }
    out
}

fn albedo_sh_section(sh: &AlbedoSh) -> Vec<u8> {
    // The sphere count is the model's own (coefficients / order²); the reader compares it
    // with the sphere set.
    let sphere_count = sh.coefficients.len().checked_div(sh.coefficients_per_sphere()).unwrap_or(0);
    let mut out = Vec::with_capacity(16 + 12 * sh.coefficients.len());
    put_u32(&mut out, len_u32(sphere_count));
    out.push(sh.order);
    out.push(sh.colour_space.code());
    out.push(sh.basis.code());
    out.extend_from_slice(&[0; 9]);
    for c in &sh.coefficients {
        put_f32s(&mut out, c);
    }
    out
}

fn skin_section(skin: &SkinTerms) -> Vec<u8> {
    let sphere_count =
        usize::try_from(skin.bones_per_sphere).ok().and_then(|k| skin.entries.len().checked_div(k)).unwrap_or(0);
    let mut out = Vec::with_capacity(16 + 20 * skin.entries.len());
    put_u32(&mut out, len_u32(sphere_count));
    put_u32(&mut out, skin.bones_per_sphere);
    out.extend_from_slice(&[0; 8]);
    for e in &skin.entries {
        put_u32(&mut out, e.bone);
        put_f32s(&mut out, &e.q);
        put_f32(&mut out, e.b);
    }
    out
}

fn bones_section(bones: &[BoneRecord]) -> Vec<u8> {
    let name_bytes: usize = bones.iter().map(|b| b.name.len()).sum();
    let mut out = Vec::new();
    put_u32(&mut out, len_u32(bones.len()));
    put_u32(&mut out, len_u32(name_bytes));
    out.extend_from_slice(&[0; 8]);
    let mut name_offset = 0usize;
    for b in bones {
        put_u32(&mut out, b.parent.unwrap_or(NO_PARENT));
        put_u32(&mut out, len_u32(name_offset));
        put_u32(&mut out, len_u32(b.name.len()));
        put_u32(&mut out, 0);
        put_f32s(&mut out, &b.inverse_bind);
        name_offset = name_offset.saturating_add(b.name.len());
    }
    for b in bones {
        out.extend_from_slice(b.name.as_bytes());
    }
    out
}

fn metadata_section(m: &Metadata) -> Vec<u8> {
    let mut pairs: Vec<(&str, &str)> = Vec::with_capacity(4 + m.extra.len());
    pairs.push(("tool_version", &m.tool_version));
    pairs.push(("settings", &m.settings));
    pairs.push(("input_hash", &m.input_hash));
    pairs.push(("units", &m.units));
    for (k, v) in &m.extra {
        pairs.push((k, v));
    }
    let string_bytes: usize = pairs.iter().map(|(k, v)| k.len() + v.len()).sum();
    let mut out = Vec::new();
    put_u32(&mut out, len_u32(pairs.len()));
    put_u32(&mut out, len_u32(string_bytes));
    out.extend_from_slice(&[0; 8]);
    let mut at = 0usize;
    for (k, v) in &pairs {
        put_u32(&mut out, len_u32(at));
        put_u32(&mut out, len_u32(k.len()));
        at = at.saturating_add(k.len());
        put_u32(&mut out, len_u32(at));
        put_u32(&mut out, len_u32(v.len()));
        at = at.saturating_add(v.len());
    }
    for (k, v) in &pairs {
        out.extend_from_slice(k.as_bytes());
        out.extend_from_slice(v.as_bytes());
    }
    out
}

fn lossless_sections(file: &SphbFile) -> Vec<(SectionKind, Vec<u8>)> {
    let mut sections: Vec<(SectionKind, Vec<u8>)> = Vec::with_capacity(7);
    sections.push((SectionKind::Spheres, spheres_section(&file.spheres)));
    if let Some(h) = &file.hierarchy {
        sections.push((SectionKind::Hierarchy, hierarchy_section(h)));
    }
    if let Some(s) = &file.samples {
        sections.push((SectionKind::Samples, samples_section(s)));
    }
    if let Some(sh) = &file.albedo_sh {
        sections.push((SectionKind::AlbedoSh, albedo_sh_section(sh)));
    }
    if let Some(skin) = &file.skin {
        sections.push((SectionKind::Skin, skin_section(skin)));
    }
    if let Some(bones) = &file.bones {
        sections.push((SectionKind::Bones, bones_section(bones)));
    }
    if let Some(m) = &file.metadata {
        sections.push((SectionKind::Metadata, metadata_section(m)));
    }
    if let Some(a) = file.samples.as_ref().and_then(|s| s.areas.as_ref()) {
        sections.push((SectionKind::SampleAreas, sample_areas_section(a)));
    }
    sections
}

/// The `sample_areas` section (spec §7.2), encoding 0: f32 areas in model units².
fn sample_areas_section(areas: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + 4 * areas.len());
    put_u32(&mut out, len_u32(areas.len()));
    out.extend_from_slice(&[0; 12]);
    put_f32s(&mut out, areas);
    out
}

/// The `sample_areas` section in encoding 1 (spec §7.2): each area as the f16 of area / r², r
/// its sphere's radius; `None` when a value does not fit (a radius that is not finite and > 0,
/// an area that is not finite and ≥ 0, a ratio past the f16 range), and the writer falls back to
/// encoding 0.
fn compact_sample_areas_section(areas: &[f32], samples: &Samples, spheres: &[Sphere]) -> Option<Vec<u8>> {
    if areas.len() != samples.total() {
        return None;
    }
    let mut out = Vec::with_capacity(16 + 2 * areas.len());
    put_u32(&mut out, len_u32(areas.len()));
    out.push(1);
    out.extend_from_slice(&[0; 11]);
    for sphere in 0..samples.sphere_count() {
        let range = samples.range_of(sphere);
        if range.is_empty() {
            continue;
        }
        let r = f64::from(spheres.get(sphere)?.radius);
        if !(r.is_finite() && r > 0.0) {
            return None;
        }
        for k in range {
            let a = *areas.get(k)?;
            if !(a.is_finite() && a >= 0.0) {
                return None;
            }
            let bits = f16_from_f32((f64::from(a) / (r * r)) as f32)?;
            out.extend_from_slice(&bits.to_le_bytes());
        }
    }
    Some(out)
}

/// The minor to stamp (spec §13): 2 with `sample_areas`, else `base` (0 for [`write`], 1 for
/// [`write_compact`], which has always stamped 1).
fn minor_of(sections: &[(SectionKind, Vec<u8>)], base: u16) -> u16 {
    if sections.iter().any(|(s, _)| *s == SectionKind::SampleAreas) {
        2
    } else {
        base
    }
}

/// Header, table and the given sections (in the given order) with zero padding.
fn assemble(minor: u16, sections: &[(SectionKind, Vec<u8>)]) -> Vec<u8> {
    let table_offset = HEADER_SIZE;
    let table_len = SECTION_ENTRY_SIZE * sections.len();
    let mut out = alloc::vec![0; table_offset + table_len];
    pad_to_align(&mut out);
    let mut entries: Vec<u8> = Vec::with_capacity(table_len);
    for (kind, body) in sections {
        let offset = out.len() as u64;
        put_u32(&mut entries, kind.code());
        put_u32(&mut entries, 0);
        entries.extend_from_slice(&offset.to_le_bytes());
        entries.extend_from_slice(&(body.len() as u64).to_le_bytes());
        put_u32(&mut entries, crc32fast::hash(body));
        put_u32(&mut entries, 0);
        out.extend_from_slice(body);
        pad_to_align(&mut out);
    }
    let file_size = out.len() as u64;
    if let Some(table) = out.get_mut(table_offset..table_offset + table_len) {
        table.copy_from_slice(&entries);
    }

    let mut header: Vec<u8> = Vec::with_capacity(HEADER_SIZE);
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&FORMAT_MAJOR.to_le_bytes());
    header.extend_from_slice(&minor.to_le_bytes());
    put_u32(&mut header, len_u32(HEADER_SIZE));
    put_u32(&mut header, 0);
    put_u32(&mut header, len_u32(sections.len()));
    header.extend_from_slice(&(table_offset as u64).to_le_bytes());
    header.extend_from_slice(&file_size.to_le_bytes());
    put_u32(&mut header, crc32fast::hash(&entries));
    let header_crc = crc32fast::hash(&header);
    put_u32(&mut header, header_crc);
    header.resize(HEADER_SIZE, 0);
    if let Some(h) = out.get_mut(..HEADER_SIZE) {
        h.copy_from_slice(&header);
    }
    out
}

/// Encodes `file` as lossless `.sphb` v1 bytes: format version 1.0 (no minor-1 section is used,
/// so v1.0 readers read everything), or 1.2 when the samples carry areas (the `sample_areas`
/// section, kind 10, which v1.0 and v1.1 readers skip).
///
/// The output is deterministic: the same model gives the same bytes, sections are written in
/// ascending kind order, every padding and reserved byte is zero.
/// Floats are stored bit for bit.
/// The writer does not validate; a model that breaks a rule (say a radius of 0 or a leaf index
/// past the sphere count) gives bytes that [`read`](crate::read) rejects with that rule.
///
/// # Panics
///
/// Never.
#[must_use]
pub fn write(file: &SphbFile) -> Vec<u8> {
    let sections = lossless_sections(file);
    assemble(minor_of(&sections, 0), &sections)
}

/// Why [`write_compact`] cannot encode a model: a value the compact sections cannot hold.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EncodeError {
    /// A sample position is not finite, or its sphere's box step overflows f32.
    SamplePosition {
        /// Sphere index.
        sphere: usize,
    },
    /// A sample normal is zero or not finite.
    SampleNormal {
        /// Sphere index.
        sphere: usize,
        /// Index of the sample within the sphere.
        sample: usize,
    },
    /// An SH coefficient is not finite or outside the f16 range (|x| < 65520).
    ShCoefficient {
        /// Index into [`AlbedoSh::coefficients`].
        index: usize,
        /// The value.
        value: f32,
    },
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EncodeError::SamplePosition { sphere } => {
                write!(
                    f,
                    "compact samples: sphere {sphere} has a non-finite sample position or a box too large for f32"
                )
            }
            EncodeError::SampleNormal { sphere, sample } => {
                write!(f, "compact samples: sample {sample} of sphere {sphere} has a zero or non-finite normal")
            }
            EncodeError::ShCoefficient { index, value } => {
                write!(f, "compact albedo SH: coefficient {index} is {value:?}, outside the f16 range (|x| < 65520)")
            }
        }
    }
}

impl core::error::Error for EncodeError {}

/// The `samples_q16` section (spec §7.1).
fn compact_samples_section(s: &Samples) -> Result<Vec<u8>, EncodeError> {
    let total = s.total();
    let n = s.sphere_count();
    let mut out = Vec::with_capacity(16 + 4 * (n + 1) + 16 + 24 * n + 12 * total);
    put_u32(&mut out, len_u32(n));
    put_u32(&mut out, len_u32(total));
    out.extend_from_slice(&[0; 8]);
    let mut offset = 0usize;
    put_u32(&mut out, 0);
    for points in s.per_sphere() {
        offset = offset.saturating_add(points.len());
        put_u32(&mut out, len_u32(offset));
    }
    pad_to_align(&mut out);
    let mut boxes = Vec::with_capacity(n);
    for (sphere, points) in s.per_sphere().enumerate() {
        let b = SampleBox::enclosing(points.iter().map(|p| p.position))
            .filter(SampleBox::is_valid)
            .ok_or(EncodeError::SamplePosition { sphere })?;
        put_f32s(&mut out, &b.origin);
        put_f32s(&mut out, &b.step);
        boxes.push(b);
    }
    for (sphere, (points, b)) in s.per_sphere().zip(&boxes).enumerate() {
        for (sample, p) in points.iter().enumerate() {
            for q in b.quantise(p.position) {
                out.extend_from_slice(&q.to_le_bytes());
            }
            let oct = oct_encode(p.normal).ok_or(EncodeError::SampleNormal { sphere, sample })?;
            for c in oct {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.push(p.direction);
            out.push(p.rule);
        }
    }
    Ok(out)
}

/// The `albedo_sh_f16` section (spec §8.1).
fn compact_albedo_sh_section(sh: &AlbedoSh) -> Result<Vec<u8>, EncodeError> {
    let sphere_count = sh.coefficients.len().checked_div(sh.coefficients_per_sphere()).unwrap_or(0);
    let mut out = Vec::with_capacity(16 + 6 * sh.coefficients.len());
    put_u32(&mut out, len_u32(sphere_count));
    out.push(sh.order);
    out.push(sh.colour_space.code());
    out.push(sh.basis.code());
    out.extend_from_slice(&[0; 9]);
    for (i, c) in sh.coefficients.iter().enumerate() {
        for &v in c {
            let bits = f16_from_f32(v).ok_or(EncodeError::ShCoefficient { index: i, value: v })?;
            out.extend_from_slice(&bits.to_le_bytes());
        }
    }
    Ok(out)
}

/// Encodes `file` as compact `.sphb` bytes, format version 1.1 (1.2 with sample areas, stored
/// as f16 in units of their sphere's r², spec §7.2): like [`write`], but samples go
/// to a `samples_q16` section (kind 8: positions in 16 bits per axis within a per-sphere box,
/// octahedral 2 × 16-bit normals) and the albedo SH to an `albedo_sh_f16` section (kind 9:
/// binary16 coefficients). Every other section is the lossless one, byte for byte.
///
/// A v1.0 reader skips the two compact sections and reads the rest: it sees a valid file
/// without samples and albedo (the shadow query needs neither). [`read`](crate::read) of this
/// crate decodes them back into [`Samples`] and [`AlbedoSh`] within the error bounds of
/// [`quant`](crate::quant).
///
/// Deterministic like [`write`].
///
/// # Errors
///
/// A value the compact sections cannot hold: a non-finite sample position, a zero or
/// non-finite normal, an SH coefficient outside the f16 range.
///
/// # Panics
///
/// Never.
pub fn write_compact(file: &SphbFile) -> Result<Vec<u8>, EncodeError> {
    let mut sections: Vec<(SectionKind, Vec<u8>)> = lossless_sections(file)
        .into_iter()
        .filter(|(k, _)| !matches!(k, SectionKind::Samples | SectionKind::AlbedoSh | SectionKind::SampleAreas))
        .collect();
    if let Some(s) = &file.samples {
        sections.push((SectionKind::CompactSamples, compact_samples_section(s)?));
    }
    if let Some(sh) = &file.albedo_sh {
        sections.push((SectionKind::CompactAlbedoSh, compact_albedo_sh_section(sh)?));
    }
    // Kind 10 after 8 and 9: sections stay in ascending kind order. The areas in encoding 1
    // (f16 per r², 2 bytes per sample), or f32 when a value does not fit.
    if let Some(s) = &file.samples {
        if let Some(a) = &s.areas {
            let body = compact_sample_areas_section(a, s, &file.spheres).unwrap_or_else(|| sample_areas_section(a));
            sections.push((SectionKind::SampleAreas, body));
        }
    }
    Ok(assemble(minor_of(&sections, 1), &sections))
}

impl SphbFile {
    /// Encodes this file; see [`write`](fn@crate::write).
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        write(self)
    }
}
