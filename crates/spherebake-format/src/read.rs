//! The validating reader.
//!
//! Every offset is computed with checked arithmetic and every access goes through
//! `slice::get`, so no byte string can make it panic or read out of bounds.
//! Counts are trusted for allocation only after the section length that bounds them was checked.

use alloc::string::String;
use alloc::vec;
use alloc::vec::Vec;

use crate::error::{Detail, Rule, SectionKind, ValidationError};
use crate::model::{
    AlbedoSh, BoneRecord, ColourSpace, Hierarchy, HierarchyNode, Metadata, SamplePoint, Samples, ShBasis, SkinEntry,
    SkinTerms, SphbFile, Sphere, DIRECTION_COUNT, MAX_BONES_PER_SPHERE, MAX_SH_ORDER, NO_PARENT, UNUSED_BONE,
};
use crate::quant::{f16_is_finite, f32_from_f16, oct_decode, SampleBox};
use crate::{ALIGN, FORMAT_MAJOR, FORMAT_MINOR, HEADER_CRC_RANGE_END, HEADER_SIZE, MAGIC, SECTION_ENTRY_SIZE};

type Result<T> = core::result::Result<T, ValidationError>;

/// The fixed part of the file header, as read.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Major format version (1).
    pub major: u16,
    /// Minor format version; any minor of major 1 is accepted.
    pub minor: u16,
    /// Header size in bytes (64 in v1.0).
    pub header_size: u32,
    /// Reserved flags (written as 0, ignored by v1.0 readers).
    pub flags: u32,
    /// Number of section table entries.
    pub section_count: u32,
    /// Byte offset of the section table.
    pub table_offset: u64,
    /// Total file size in bytes.
    pub file_size: u64,
    /// CRC-32 of the section table bytes.
    pub table_crc32: u32,
    /// CRC-32 of header bytes 0..44.
    pub header_crc32: u32,
}

/// One section table entry, as read.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SectionEntry {
    /// Raw kind code; see [`SectionKind::from_code`].
    pub kind: u32,
    /// Byte offset of the section from the start of the file (multiple of 16).
    pub offset: u64,
    /// Section length in bytes, padding excluded.
    pub length: u64,
    /// CRC-32 (IEEE, as `crc32fast`) of the section bytes.
    pub crc32: u32,
}

impl SectionEntry {
    /// The known kind, `None` for a kind this reader skips.
    #[must_use]
    pub fn known_kind(&self) -> Option<SectionKind> {
        SectionKind::from_code(self.kind)
    }
}

fn err(rule: Rule, section: Option<SectionKind>, offset: u64, expected: Detail, actual: Detail) -> ValidationError {
    ValidationError::new(rule, section, offset, expected, actual)
}

fn as_u64(v: usize) -> u64 {
    u64::try_from(v).unwrap_or(u64::MAX)
}

fn bytes_at<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    let end = at.checked_add(N)?;
    bytes.get(at..end)?.try_into().ok()
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    bytes_at::<2>(bytes, at).map(u16::from_le_bytes)
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    bytes_at::<4>(bytes, at).map(u32::from_le_bytes)
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    bytes_at::<8>(bytes, at).map(u64::from_le_bytes)
}

/// Reads and validates the header and the section table (rules 1xxx and 2xxx).
///
/// Section contents are not decoded; use [`read`] for that.
/// Tools use this to list sections, including unknown ones.
///
/// # Errors
///
/// The first violated header or section table rule.
pub fn read_header_and_table(bytes: &[u8]) -> Result<(Header, Vec<SectionEntry>)> {
    let len = bytes.len();
    let len64 = as_u64(len);
    let hdr = |rule, offset: usize, expected, actual| err(rule, None, as_u64(offset), expected, actual);
    if len < HEADER_SIZE {
        return Err(hdr(Rule::FileTooSmall, 0, Detail::Int(as_u64(HEADER_SIZE)), Detail::Int(len64)));
    }
    let truncated = || hdr(Rule::FileTooSmall, 0, Detail::Int(64), Detail::Int(len64));
    if bytes.get(..8) != Some(&MAGIC[..]) {
        return Err(hdr(Rule::BadMagic, 0, Detail::Text("magic"), Detail::Text("other bytes")));
    }
    let major = u16_at(bytes, 8).ok_or_else(truncated)?;
    let minor = u16_at(bytes, 10).ok_or_else(truncated)?;
    let header_size = u32_at(bytes, 12).ok_or_else(truncated)?;
    let flags = u32_at(bytes, 16).ok_or_else(truncated)?;
    let section_count = u32_at(bytes, 20).ok_or_else(truncated)?;
    let table_offset = u64_at(bytes, 24).ok_or_else(truncated)?;
    let file_size = u64_at(bytes, 32).ok_or_else(truncated)?;
    let table_crc32 = u32_at(bytes, 40).ok_or_else(truncated)?;
    let header_crc32 = u32_at(bytes, 44).ok_or_else(truncated)?;
    if major != FORMAT_MAJOR {
        return Err(hdr(
            Rule::UnsupportedMajor,
            8,
            Detail::Int(u64::from(FORMAT_MAJOR)),
            Detail::Int(u64::from(major)),
        ));
    }
    let newer_minor = minor > FORMAT_MINOR;
    let header_size_ok = if !newer_minor {
        usize::try_from(header_size) == Ok(HEADER_SIZE)
    } else {
        header_size as usize >= HEADER_SIZE && header_size as usize % ALIGN == 0 && u64::from(header_size) <= len64
    };
    if !header_size_ok {
        return Err(hdr(Rule::HeaderSize, 12, Detail::Int(as_u64(HEADER_SIZE)), Detail::Int(u64::from(header_size))));
    }
    let computed = crc32fast::hash(bytes.get(..HEADER_CRC_RANGE_END).ok_or_else(truncated)?);
    if computed != header_crc32 {
        return Err(hdr(
            Rule::HeaderChecksum,
            44,
            Detail::Int(u64::from(computed)),
            Detail::Int(u64::from(header_crc32)),
        ));
    }
    if file_size != len64 {
        return Err(hdr(Rule::FileSize, 32, Detail::Int(len64), Detail::Int(file_size)));
    }
    if len % ALIGN != 0 {
        return Err(hdr(Rule::FileAlignment, 32, Detail::Text("multiple of 16"), Detail::Int(len64)));
    }
    let header =
        Header { major, minor, header_size, flags, section_count, table_offset, file_size, table_crc32, header_crc32 };

    if table_offset % ALIGN as u64 != 0 || table_offset < u64::from(header_size) {
        return Err(hdr(
            Rule::TableOffset,
            24,
            Detail::Text("multiple of 16, at least the header size"),
            Detail::Int(table_offset),
        ));
    }
    let table_len = u64::from(section_count).checked_mul(SECTION_ENTRY_SIZE as u64);
    let table_end = table_len.and_then(|l| table_offset.checked_add(l));
    let table_range = match table_end {
        Some(end) if end <= len64 => {
            // Both bounds are at most `len`, so they fit in usize.
            (table_offset as usize)..(end as usize)
        }
        _ => {
            return Err(hdr(
                Rule::TableBounds,
                20,
                Detail::Int(len64),
                Detail::Text("table end past the end of the file"),
            ))
        }
    };
    let table_start = table_range.start;
    let table_end = table_range.end;
    let table = bytes.get(table_range).ok_or_else(truncated)?;
    let computed = crc32fast::hash(table);
    if computed != table_crc32 {
        return Err(hdr(
            Rule::TableChecksum,
            40,
            Detail::Int(u64::from(computed)),
            Detail::Int(u64::from(table_crc32)),
        ));
    }

    let mut entries = Vec::with_capacity(section_count as usize);
    let mut seen_known = [false; SectionKind::ALL.len()];
    // Lossless and compact sections of the same data (samples / samples_q16, albedo_sh / albedo_sh_f16).
    let mut seen_family = [false; SectionKind::ALL.len()];
    // End of the previous region (table or section); also where zero padding starts.
    let mut prev_end = table_end;
    // Zero-padding check of the gap between the header and the table.
    check_zero(bytes, header_size as usize, table_start)?;
    for i in 0..section_count as usize {
        let at = i.checked_mul(SECTION_ENTRY_SIZE).ok_or_else(truncated)?;
        let field = |rel: usize| table_start.saturating_add(at).saturating_add(rel);
        let kind = u32_at(table, at).ok_or_else(truncated)?;
        let offset = u64_at(table, at + 8).ok_or_else(truncated)?;
        let length = u64_at(table, at + 16).ok_or_else(truncated)?;
        let crc = u32_at(table, at + 24).ok_or_else(truncated)?;
        let known = SectionKind::from_code(kind);
        if offset % ALIGN as u64 != 0 {
            return Err(hdr(Rule::SectionAlignment, field(8), Detail::Text("multiple of 16"), Detail::Int(offset)));
        }
        let end = offset.checked_add(length);
        let range = match end {
            Some(end) if offset >= as_u64(table_end) && end <= len64 => (offset as usize)..(end as usize),
            _ => return Err(hdr(Rule::SectionBounds, field(8), Detail::Int(len64), Detail::Int(offset))),
        };
        if range.start < prev_end {
            return Err(hdr(Rule::SectionOrder, field(8), Detail::Int(as_u64(prev_end)), Detail::Int(offset)));
        }
        if let Some(k) = known {
            let slot = SectionKind::ALL.iter().position(|&x| x == k).unwrap_or(0);
            if let Some(seen) = seen_known.get_mut(slot) {
                if *seen {
                    return Err(hdr(
                        Rule::DuplicateSection,
                        field(0),
                        Detail::Text("kind at most once"),
                        Detail::Int(u64::from(kind)),
                    ));
                }
                *seen = true;
            }
            let family = SectionKind::ALL.iter().position(|&x| x == k.family()).unwrap_or(0);
            if let Some(seen) = seen_family.get_mut(family) {
                if *seen {
                    return Err(hdr(
                        Rule::SectionConflict,
                        field(0),
                        Detail::Text("one section per family"),
                        Detail::Int(u64::from(kind)),
                    ));
                }
                *seen = true;
            }
        }
        check_zero(bytes, prev_end, range.start)?;
        let data = bytes.get(range.clone()).ok_or_else(truncated)?;
        let computed = crc32fast::hash(data);
        if computed != crc {
            return Err(hdr(
                Rule::SectionChecksum,
                field(24),
                Detail::Int(u64::from(computed)),
                Detail::Int(u64::from(crc)),
            ));
        }
        prev_end = range.end;
        entries.push(SectionEntry { kind, offset, length, crc32: crc });
    }
    check_zero(bytes, prev_end, len)?;
    Ok((header, entries))
}

fn check_zero(bytes: &[u8], start: usize, end: usize) -> Result<()> {
    if let Some(gap) = bytes.get(start..end) {
        if let Some(pos) = gap.iter().position(|&b| b != 0) {
            let at = start.saturating_add(pos);
            return Err(err(
                Rule::NonZeroPadding,
                None,
                as_u64(at),
                Detail::Int(0),
                Detail::Int(u64::from(gap.get(pos).copied().unwrap_or(0))),
            ));
        }
    }
    Ok(())
}

/// A section's bytes with its absolute offset, for error reporting.
struct Sec<'a> {
    data: &'a [u8],
    base: u64,
    kind: SectionKind,
    length_rule: Rule,
    /// Whether the length must match exactly (file minor <= reader minor).
    exact: bool,
}

impl<'a> Sec<'a> {
    fn at(&self, rel: usize) -> u64 {
        self.base.saturating_add(as_u64(rel))
    }

    fn err(&self, rule: Rule, rel: usize, expected: Detail, actual: Detail) -> ValidationError {
        err(rule, Some(self.kind), self.at(rel), expected, actual)
    }

    fn short(&self, rel: usize) -> ValidationError {
        self.err(self.length_rule, rel, Detail::Text("field inside the section"), Detail::Int(as_u64(self.data.len())))
    }

    fn u8(&self, rel: usize) -> Result<u8> {
        self.data.get(rel).copied().ok_or_else(|| self.short(rel))
    }

    fn u16(&self, rel: usize) -> Result<u16> {
        u16_at(self.data, rel).ok_or_else(|| self.short(rel))
    }

    fn u32(&self, rel: usize) -> Result<u32> {
        u32_at(self.data, rel).ok_or_else(|| self.short(rel))
    }

    /// `count` consecutive u32 values from `rel` (bounded by the section length).
    fn u32s(&self, rel: usize, count: usize) -> Result<Vec<u32>> {
        let end = count.checked_mul(4).and_then(|l| rel.checked_add(l)).ok_or_else(|| self.short(rel))?;
        let raw = self.data.get(rel..end).ok_or_else(|| self.short(rel))?;
        Ok(raw.chunks_exact(4).map(|c| c.try_into().map_or(0, u32::from_le_bytes)).collect())
    }

    fn f32(&self, rel: usize) -> Result<f32> {
        bytes_at::<4>(self.data, rel).map(f32::from_le_bytes).ok_or_else(|| self.short(rel))
    }

    fn f32s<const N: usize>(&self, rel: usize) -> Result<[f32; N]> {
        let mut out = [0.0; N];
        for (i, v) in out.iter_mut().enumerate() {
            *v = self.f32(rel.saturating_add(i * 4))?;
        }
        Ok(out)
    }

    /// Checks the 16-byte sub-header is present.
    fn need_subheader(&self) -> Result<()> {
        if self.data.len() < 16 {
            return Err(self.err(
                self.length_rule,
                0,
                Detail::Text("at least 16"),
                Detail::Int(as_u64(self.data.len())),
            ));
        }
        Ok(())
    }

    /// Checks the section length against `required` (`None` = the size overflowed).
    fn check_length(&self, required: Option<u64>) -> Result<()> {
        let actual = as_u64(self.data.len());
        let ok = match required {
            Some(r) if self.exact => r == actual,
            Some(r) => r <= actual,
            None => false,
        };
        if ok {
            Ok(())
        } else {
            Err(self.err(
                self.length_rule,
                0,
                required.map_or(Detail::Text("size below 2^64"), Detail::Int),
                Detail::Int(actual),
            ))
        }
    }
}

fn mul(a: u64, b: u64) -> Option<u64> {
    a.checked_mul(b)
}

fn add(a: Option<u64>, b: Option<u64>) -> Option<u64> {
    a?.checked_add(b?)
}

fn finite3(v: &[f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn first_nonfinite(v: &[f32]) -> Option<(usize, f32)> {
    v.iter().copied().enumerate().find(|(_, x)| !x.is_finite())
}

fn read_spheres(s: &Sec<'_>) -> Result<Vec<Sphere>> {
    s.need_subheader()?;
    let count = s.u32(0)?;
    s.check_length(add(Some(16), mul(u64::from(count), 16)))?;
    if count == 0 {
        return Err(s.err(Rule::SpheresEmpty, 0, Detail::Text(">= 1"), Detail::Int(0)));
    }
    let mut out = Vec::with_capacity(count as usize);
    for i in 0..count as usize {
        let rel = 16 + 16 * i;
        let center = s.f32s::<3>(rel)?;
        let radius = s.f32(rel + 12)?;
        if let Some((j, v)) = first_nonfinite(&center) {
            return Err(s.err(Rule::SphereCentre, rel + 4 * j, Detail::Text("finite"), Detail::Float(v)));
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(s.err(Rule::SphereRadius, rel + 12, Detail::Text("finite and > 0"), Detail::Float(radius)));
        }
        out.push(Sphere { center, radius });
    }
    Ok(out)
}

fn read_hierarchy(s: &Sec<'_>, sphere_count: usize) -> Result<Hierarchy> {
    s.need_subheader()?;
    let node_count = s.u32(0)?;
    let root = s.u32(4)?;
    let child_total = s.u32(8)?;
    let leaf_total = s.u32(12)?;
    let required =
        add(add(Some(16), mul(u64::from(node_count), 32)), mul(u64::from(child_total) + u64::from(leaf_total), 4));
    s.check_length(required)?;
    if node_count == 0 {
        return Err(s.err(Rule::HierarchyEmpty, 0, Detail::Text(">= 1"), Detail::Int(0)));
    }
    if root >= node_count {
        return Err(s.err(Rule::HierarchyRoot, 4, Detail::Int(u64::from(node_count)), Detail::Int(u64::from(root))));
    }
    // Bounded by the section length checked above.
    let n = node_count as usize;
    let children_base = 16 + 32 * n;
    let leaves_base = children_base + 4 * child_total as usize;
    let children = s.u32s(children_base, child_total as usize)?;
    let leaves = s.u32s(leaves_base, leaf_total as usize)?;
    let mut nodes = Vec::with_capacity(n);
    for i in 0..n {
        let rel = 16 + 32 * i;
        let center = s.f32s::<3>(rel)?;
        let radius = s.f32(rel + 12)?;
        let first_child = s.u32(rel + 16)?;
        let child_count = s.u32(rel + 20)?;
        let first_leaf = s.u32(rel + 24)?;
        let leaf_count = s.u32(rel + 28)?;
        if let Some((j, v)) = first_nonfinite(&center) {
            return Err(s.err(Rule::NodeCentre, rel + 4 * j, Detail::Text("finite"), Detail::Float(v)));
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(s.err(Rule::NodeRadius, rel + 12, Detail::Text("finite and > 0"), Detail::Float(radius)));
        }
        let child_end = u64::from(first_child) + u64::from(child_count);
        if child_end > u64::from(child_total) {
            return Err(s.err(
                Rule::NodeChildRange,
                rel + 16,
                Detail::Int(u64::from(child_total)),
                Detail::Int(child_end),
            ));
        }
        let leaf_end = u64::from(first_leaf) + u64::from(leaf_count);
        if leaf_end > u64::from(leaf_total) {
            return Err(s.err(
                Rule::NodeLeafRange,
                rel + 24,
                Detail::Int(u64::from(leaf_total)),
                Detail::Int(leaf_end),
            ));
        }
        if child_count == 0 && leaf_count == 0 {
            return Err(s.err(Rule::NodeEmpty, rel + 20, Detail::Text(">= 1 child or leaf"), Detail::Int(0)));
        }
        // Ranges were checked against the array lengths above.
        for c in 0..child_count as usize {
            let k = first_child as usize + c;
            let at = children_base + 4 * k;
            let idx = children.get(k).copied().ok_or_else(|| s.short(at))?;
            if idx >= node_count {
                return Err(s.err(
                    Rule::ChildIndex,
                    at,
                    Detail::Int(u64::from(node_count)),
                    Detail::Int(u64::from(idx)),
                ));
            }
        }
        for l in 0..leaf_count as usize {
            let k = first_leaf as usize + l;
            let at = leaves_base + 4 * k;
            let idx = leaves.get(k).copied().ok_or_else(|| s.short(at))?;
            if idx as usize >= sphere_count {
                return Err(s.err(Rule::LeafIndex, at, Detail::Int(as_u64(sphere_count)), Detail::Int(u64::from(idx))));
            }
        }
        nodes.push(HierarchyNode { center, radius, first_child, child_count, first_leaf, leaf_count });
    }

    let h = Hierarchy { root, nodes, children, leaves };
    // Iterative depth-first walk: no recursion, so no stack overflow on deep trees.
    let mut node_seen = vec![false; n];
    let mut leaf_seen = vec![false; sphere_count];
    let mut stack = vec![root];
    while let Some(i) = stack.pop() {
        let rel = 16 + 32 * i as usize;
        let Some(seen) = node_seen.get_mut(i as usize) else {
            return Err(s.short(rel));
        };
        if *seen {
            return Err(s.err(Rule::NodeRevisited, rel, Detail::Text("reached once"), Detail::Int(u64::from(i))));
        }
        *seen = true;
        for &leaf in h.leaves_of(i as usize) {
            match leaf_seen.get_mut(leaf as usize) {
                Some(l) if !*l => *l = true,
                _ => {
                    return Err(s.err(
                        Rule::LeafRevisited,
                        rel + 24,
                        Detail::Text("sphere is a leaf once"),
                        Detail::Int(u64::from(leaf)),
                    ))
                }
            }
        }
        stack.extend(h.children_of(i as usize).iter().rev());
    }
    if let Some(i) = node_seen.iter().position(|&v| !v) {
        return Err(s.err(
            Rule::NodeUnreachable,
            16 + 32 * i,
            Detail::Text("reachable from the root"),
            Detail::Int(as_u64(i)),
        ));
    }
    if let Some(i) = leaf_seen.iter().position(|&v| !v) {
        return Err(s.err(
            Rule::LeafUnreachable,
            leaves_base,
            Detail::Text("every sphere reachable"),
            Detail::Int(as_u64(i)),
        ));
    }
    Ok(h)
}

const fn pad16(v: u64) -> u64 {
    (v + 15) & !15
}

fn read_samples(s: &Sec<'_>, sphere_count: usize) -> Result<Samples> {
    s.need_subheader()?;
    let sc = s.u32(0)?;
    let total = s.u32(4)?;
    let offsets_len = pad16(4 * (u64::from(sc) + 1));
    let required = add(add(Some(16), Some(offsets_len)), mul(u64::from(total), 32));
    s.check_length(required)?;
    if sc as usize != sphere_count {
        return Err(s.err(Rule::SamplesSphereCount, 0, Detail::Int(as_u64(sphere_count)), Detail::Int(u64::from(sc))));
    }
    let base = 16 + offsets_len as usize;
    let ends = sample_offsets(s, sphere_count, total)?;
    let mut offsets = Vec::with_capacity(sphere_count + 1);
    offsets.push(0u32);
    let mut points = Vec::with_capacity(total as usize);
    let mut start = 0u32;
    for &end in &ends {
        let mut prev_direction: Option<u8> = None;
        for j in start as usize..end as usize {
            let rel = base + 32 * j;
            let position = s.f32s::<3>(rel)?;
            let normal = s.f32s::<3>(rel + 12)?;
            let direction = s.u8(rel + 24)?;
            let rule = s.u8(rel + 25)?;
            if let Some((k, v)) = first_nonfinite(&position) {
                return Err(s.err(Rule::SamplePosition, rel + 4 * k, Detail::Text("finite"), Detail::Float(v)));
            }
            let len2: f64 = normal.iter().map(|&x| f64::from(x) * f64::from(x)).sum();
            // |n| within 1e-3 of 1, tested on the squared length (no sqrt in no_std core).
            let (lo, hi) = ((1.0f64 - 1e-3) * (1.0 - 1e-3), (1.0f64 + 1e-3) * (1.0 + 1e-3));
            if !finite3(&normal) || !(lo..=hi).contains(&len2) {
                return Err(s.err(
                    Rule::SampleNormal,
                    rel + 12,
                    Detail::Text("finite unit vector"),
                    Detail::Float(len2 as f32),
                ));
            }
            check_direction_rule(s, direction, rule, prev_direction, rel + 24, rel + 25)?;
            prev_direction = Some(direction);
            points.push(SamplePoint { position, normal, direction, rule });
        }
        offsets.push(end);
        start = end;
    }
    Ok(Samples { offsets, points, areas: None })
}

/// The `sample_areas` section (§7.2), attached to the samples it belongs to (rules 5012–5015).
fn read_sample_areas(s: &Sec<'_>, samples: Option<Samples>, spheres: &[Sphere]) -> Result<Samples> {
    s.need_subheader()?;
    let count = s.u32(0)?;
    let encoding = s.u8(4)?;
    let width = match encoding {
        0 => 4,
        1 => 2,
        e => {
            return Err(s.err(Rule::SampleAreasEncoding, 4, Detail::Text("0 or 1"), Detail::Int(u64::from(e))));
        }
    };
    s.check_length(add(Some(16), mul(u64::from(count), width)))?;
    let Some(mut samples) = samples else {
        return Err(s.err(Rule::SampleAreasCount, 0, Detail::Text("a samples section"), Detail::Text("none")));
    };
    if count as usize != samples.total() {
        return Err(s.err(
            Rule::SampleAreasCount,
            0,
            Detail::Int(as_u64(samples.total())),
            Detail::Int(u64::from(count)),
        ));
    }
    // Bounded by the section length checked above.
    let mut areas = Vec::with_capacity(count as usize);
    for sphere in 0..samples.sphere_count() {
        let r = spheres.get(sphere).map_or(0.0, |x| f64::from(x.radius));
        for k in samples.range_of(sphere) {
            let rel = 16 + width as usize * k;
            let (a, ok) = if encoding == 0 {
                let a = s.f32(rel)?;
                (a, a.is_finite() && a >= 0.0)
            } else {
                let bits = s.u16(rel)?;
                let h = f32_from_f16(bits);
                // Decoding (§7.2): in double, (h · r) · r, rounded once to f32.
                // ≥ 0 as for f32 areas: −0 (0x8000) is 0, every other negative is refused.
                ((f64::from(h) * r * r) as f32, f16_is_finite(bits) && (bits & 0x8000 == 0 || bits == 0x8000))
            };
            if !ok {
                return Err(s.err(Rule::SampleArea, rel, Detail::Text("finite and >= 0"), Detail::Float(a)));
            }
            areas.push(a);
        }
    }
    samples.areas = Some(areas);
    Ok(samples)
}

/// Rules 5006–5008 of one sample (shared by the lossless and the compact samples sections).
fn check_direction_rule(
    s: &Sec<'_>,
    direction: u8,
    rule: u8,
    prev_direction: Option<u8>,
    rel_direction: usize,
    rel_rule: usize,
) -> Result<()> {
    if direction >= DIRECTION_COUNT {
        return Err(s.err(
            Rule::SampleDirection,
            rel_direction,
            Detail::Int(u64::from(DIRECTION_COUNT)),
            Detail::Int(u64::from(direction)),
        ));
    }
    if !(1..=3).contains(&rule) {
        return Err(s.err(Rule::SampleRule, rel_rule, Detail::Text("1, 2 or 3"), Detail::Int(u64::from(rule))));
    }
    if let Some(p) = prev_direction {
        if direction <= p {
            return Err(s.err(
                Rule::SampleDirectionOrder,
                rel_direction,
                Detail::Int(u64::from(p) + 1),
                Detail::Int(u64::from(direction)),
            ));
        }
    }
    Ok(())
}

/// Rule 5003 on the offsets table at +16 (shared by both samples sections): the end offset of
/// every sphere, after checking offsets[0] = 0, monotonicity and offsets[N] = total.
fn sample_offsets(s: &Sec<'_>, sphere_count: usize, total: u32) -> Result<Vec<u32>> {
    let first = s.u32(16)?;
    if first != 0 {
        return Err(s.err(Rule::SampleOffsets, 16, Detail::Int(0), Detail::Int(u64::from(first))));
    }
    let mut ends = Vec::with_capacity(sphere_count);
    let mut start = 0u32;
    for sphere in 0..sphere_count {
        let at = 16 + 4 * (sphere + 1);
        let end = s.u32(at)?;
        if end < start || end > total || (sphere + 1 == sphere_count && end != total) {
            return Err(s.err(
                Rule::SampleOffsets,
                at,
                Detail::Text("non-decreasing, last equals the sample count"),
                Detail::Int(u64::from(end)),
            ));
        }
        ends.push(end);
        start = end;
    }
    Ok(ends)
}

/// The compact samples section (kind 8, spec §7.1), dequantised into the same model as kind 3.
fn read_compact_samples(s: &Sec<'_>, sphere_count: usize) -> Result<Samples> {
    s.need_subheader()?;
    let sc = s.u32(0)?;
    let total = s.u32(4)?;
    let offsets_len = pad16(4 * (u64::from(sc) + 1));
    let required = add(add(add(Some(16), Some(offsets_len)), mul(u64::from(sc), 24)), mul(u64::from(total), 12));
    s.check_length(required)?;
    if sc as usize != sphere_count {
        return Err(s.err(Rule::SamplesSphereCount, 0, Detail::Int(as_u64(sphere_count)), Detail::Int(u64::from(sc))));
    }
    // Bounded by the section length checked above.
    let boxes_base = 16 + offsets_len as usize;
    let records_base = boxes_base + 24 * sphere_count;
    let ends = sample_offsets(s, sphere_count, total)?;
    let mut offsets = Vec::with_capacity(sphere_count + 1);
    offsets.push(0u32);
    let mut all = Vec::with_capacity(total as usize);
    let mut start = 0usize;
    for (sphere, &end) in ends.iter().enumerate() {
        let rel_box = boxes_base + 24 * sphere;
        let b = SampleBox { origin: s.f32s::<3>(rel_box)?, step: s.f32s::<3>(rel_box + 12)? };
        if !b.is_valid() {
            return Err(s.err(
                Rule::SampleBox,
                rel_box,
                Detail::Text("finite origin, finite step >= 0, finite far corner"),
                Detail::Text("invalid box"),
            ));
        }
        let end = end as usize;
        let mut prev_direction: Option<u8> = None;
        for j in start..end {
            let rel = records_base + 12 * j;
            let q = [s.u16(rel)?, s.u16(rel + 2)?, s.u16(rel + 4)?];
            let oct = [s.u16(rel + 6)? as i16, s.u16(rel + 8)? as i16];
            let direction = s.u8(rel + 10)?;
            let rule = s.u8(rel + 11)?;
            if let Some(k) = oct.iter().position(|&c| c == i16::MIN) {
                return Err(s.err(
                    Rule::SampleOctNormal,
                    rel + 6 + 2 * k,
                    Detail::Text("-32767..=32767"),
                    Detail::Text("-32768"),
                ));
            }
            check_direction_rule(s, direction, rule, prev_direction, rel + 10, rel + 11)?;
            prev_direction = Some(direction);
            all.push(SamplePoint { position: b.decode(q), normal: oct_decode(oct), direction, rule });
        }
        offsets.push(u32::try_from(end).unwrap_or(u32::MAX));
        start = end;
    }
    Ok(Samples { offsets, points: all, areas: None })
}

/// The albedo SH sub-header shared by kinds 4 and 9 (spec §7, §8.1): order, colour space, basis, and the
/// section length for `bytes_per_coefficient` bytes per RGB coefficient; returns them with the coefficient count.
fn read_sh_subheader(
    s: &Sec<'_>,
    sphere_count: usize,
    bytes_per_coefficient: u64,
) -> Result<(u8, ColourSpace, ShBasis, usize)> {
    s.need_subheader()?;
    let sc = s.u32(0)?;
    let order = s.u8(4)?;
    let colour = s.u8(5)?;
    let basis = s.u8(6)?;
    if !(1..=MAX_SH_ORDER).contains(&order) {
        return Err(s.err(Rule::ShOrder, 4, Detail::Text("1..=8"), Detail::Int(u64::from(order))));
    }
    let per_sphere = u64::from(order) * u64::from(order);
    s.check_length(add(Some(16), mul(u64::from(sc), bytes_per_coefficient * per_sphere)))?;
    if sc as usize != sphere_count {
        return Err(s.err(Rule::ShSphereCount, 0, Detail::Int(as_u64(sphere_count)), Detail::Int(u64::from(sc))));
    }
    let Some(colour_space) = ColourSpace::from_code(colour) else {
        return Err(s.err(Rule::ShColourSpace, 5, Detail::Int(0), Detail::Int(u64::from(colour))));
    };
    let Some(basis) = ShBasis::from_code(basis) else {
        return Err(s.err(Rule::ShBasis, 6, Detail::Int(0), Detail::Int(u64::from(basis))));
    };
    let count = sphere_count * per_sphere as usize;
    Ok((order, colour_space, basis, count))
}

fn read_albedo_sh(s: &Sec<'_>, sphere_count: usize) -> Result<AlbedoSh> {
    let (order, colour_space, basis, count) = read_sh_subheader(s, sphere_count, 12)?;
    let mut coefficients = Vec::with_capacity(count);
    for i in 0..count {
        let rel = 16 + 12 * i;
        let c = s.f32s::<3>(rel)?;
        if let Some((k, v)) = first_nonfinite(&c) {
            return Err(s.err(Rule::ShCoefficient, rel + 4 * k, Detail::Text("finite"), Detail::Float(v)));
        }
        coefficients.push(c);
    }
    Ok(AlbedoSh { order, colour_space, basis, coefficients })
}

/// The compact albedo SH section (kind 9, spec §8.1): the kind-4 sub-header, binary16 coefficients.
fn read_compact_albedo_sh(s: &Sec<'_>, sphere_count: usize) -> Result<AlbedoSh> {
    let (order, colour_space, basis, count) = read_sh_subheader(s, sphere_count, 6)?;
    let mut coefficients = Vec::with_capacity(count);
    for i in 0..count {
        let rel = 16 + 6 * i;
        let mut c = [0.0f32; 3];
        for (k, v) in c.iter_mut().enumerate() {
            let bits = s.u16(rel + 2 * k)?;
            if !f16_is_finite(bits) {
                return Err(s.err(
                    Rule::ShCoefficient,
                    rel + 2 * k,
                    Detail::Text("finite"),
                    Detail::Float(f32_from_f16(bits)),
                ));
            }
            *v = f32_from_f16(bits);
        }
        coefficients.push(c);
    }
    Ok(AlbedoSh { order, colour_space, basis, coefficients })
}

fn read_skin(s: &Sec<'_>, sphere_count: usize, bone_count: Option<usize>) -> Result<SkinTerms> {
    s.need_subheader()?;
    let sc = s.u32(0)?;
    let k = s.u32(4)?;
    if !(1..=MAX_BONES_PER_SPHERE).contains(&k) {
        return Err(s.err(Rule::SkinBonesPerSphere, 4, Detail::Text("1..=64"), Detail::Int(u64::from(k))));
    }
    s.check_length(add(Some(16), mul(u64::from(sc), 20 * u64::from(k))))?;
    if sc as usize != sphere_count {
        return Err(s.err(Rule::SkinSphereCount, 0, Detail::Int(as_u64(sphere_count)), Detail::Int(u64::from(sc))));
    }
    let Some(bone_count) = bone_count else {
        return Err(s.err(Rule::SkinWithoutBones, 0, Detail::Text("bones section"), Detail::Text("absent")));
    };
    let count = sphere_count * k as usize;
    let mut entries = Vec::with_capacity(count);
    for i in 0..count {
        let rel = 16 + 20 * i;
        let bone = s.u32(rel)?;
        let q = s.f32s::<3>(rel + 4)?;
        let b = s.f32(rel + 16)?;
        if bone != UNUSED_BONE && bone as usize >= bone_count {
            return Err(s.err(Rule::SkinBoneIndex, rel, Detail::Int(as_u64(bone_count)), Detail::Int(u64::from(bone))));
        }
        let terms = [q[0], q[1], q[2], b];
        if let Some((j, v)) = first_nonfinite(&terms) {
            return Err(s.err(Rule::SkinTerm, rel + 4 + 4 * j, Detail::Text("finite"), Detail::Float(v)));
        }
        if bone == UNUSED_BONE {
            if let Some((j, v)) = terms.iter().copied().enumerate().find(|(_, v)| *v != 0.0) {
                return Err(s.err(Rule::SkinUnusedSlot, rel + 4 + 4 * j, Detail::Float(0.0), Detail::Float(v)));
            }
        }
        entries.push(SkinEntry { bone, q, b });
    }
    Ok(SkinTerms { bones_per_sphere: k, entries })
}

fn read_bones(s: &Sec<'_>) -> Result<Vec<BoneRecord>> {
    s.need_subheader()?;
    let count = s.u32(0)?;
    let name_bytes = s.u32(4)?;
    s.check_length(add(add(Some(16), mul(u64::from(count), 80)), Some(u64::from(name_bytes))))?;
    let n = count as usize;
    let names_base = 16 + 80 * n;
    let names =
        s.data.get(names_base..names_base.saturating_add(name_bytes as usize)).ok_or_else(|| s.short(names_base))?;
    let mut bones = Vec::with_capacity(n);
    for i in 0..n {
        let rel = 16 + 80 * i;
        let parent = s.u32(rel)?;
        let name_off = s.u32(rel + 4)?;
        let name_len = s.u32(rel + 8)?;
        if parent != NO_PARENT && parent >= count {
            return Err(s.err(Rule::BoneParent, rel, Detail::Int(u64::from(count)), Detail::Int(u64::from(parent))));
        }
        let end = u64::from(name_off) + u64::from(name_len);
        let name = usize::try_from(end).ok().and_then(|e| names.get(name_off as usize..e));
        let Some(name) = name else {
            return Err(s.err(Rule::BoneNameRange, rel + 4, Detail::Int(u64::from(name_bytes)), Detail::Int(end)));
        };
        let Ok(name) = core::str::from_utf8(name) else {
            return Err(s.err(
                Rule::BoneNameUtf8,
                names_base + name_off as usize,
                Detail::Text("UTF-8"),
                Detail::Text("invalid UTF-8"),
            ));
        };
        let inverse_bind = s.f32s::<16>(rel + 16)?;
        if let Some((j, v)) = first_nonfinite(&inverse_bind) {
            return Err(s.err(Rule::BoneMatrix, rel + 16 + 4 * j, Detail::Text("finite"), Detail::Float(v)));
        }
        bones.push(BoneRecord {
            name: String::from(name),
            parent: (parent != NO_PARENT).then_some(parent),
            inverse_bind,
        });
    }
    // Cycle check in O(n): 0 = unvisited, 1 = on the current chain, 2 = known to reach a root.
    let mut state = vec![0u8; n];
    let mut chain = Vec::new();
    for start in 0..n {
        let mut cur = Some(start);
        chain.clear();
        while let Some(i) = cur {
            match state.get(i).copied() {
                Some(0) => {
                    if let Some(st) = state.get_mut(i) {
                        *st = 1;
                    }
                    chain.push(i);
                    cur = bones.get(i).and_then(|b| b.parent).map(|p| p as usize);
                }
                Some(1) => {
                    return Err(s.err(Rule::BoneCycle, 16 + 80 * i, Detail::Text("acyclic"), Detail::Int(as_u64(i))))
                }
                _ => cur = None,
            }
        }
        for &i in &chain {
            if let Some(st) = state.get_mut(i) {
                *st = 2;
            }
        }
    }
    Ok(bones)
}

fn read_metadata(s: &Sec<'_>) -> Result<Metadata> {
    s.need_subheader()?;
    let count = s.u32(0)?;
    let string_bytes = s.u32(4)?;
    s.check_length(add(add(Some(16), mul(u64::from(count), 16)), Some(u64::from(string_bytes))))?;
    let n = count as usize;
    let base = 16 + 16 * n;
    let blob = s.data.get(base..base.saturating_add(string_bytes as usize)).ok_or_else(|| s.short(base))?;
    let mut pairs: Vec<(&str, &str, usize)> = Vec::with_capacity(n);
    for i in 0..n {
        let rel = 16 + 16 * i;
        let get = |field: usize| -> Result<&str> {
            let off = s.u32(rel + field)?;
            let len = s.u32(rel + field + 4)?;
            let end = u64::from(off) + u64::from(len);
            let raw = usize::try_from(end).ok().and_then(|e| blob.get(off as usize..e));
            let Some(raw) = raw else {
                return Err(s.err(
                    Rule::MetadataStringRange,
                    rel + field,
                    Detail::Int(u64::from(string_bytes)),
                    Detail::Int(end),
                ));
            };
            core::str::from_utf8(raw).map_err(|_| {
                s.err(Rule::MetadataUtf8, base + off as usize, Detail::Text("UTF-8"), Detail::Text("invalid UTF-8"))
            })
        };
        let key = get(0)?;
        let value = get(8)?;
        if key.is_empty() {
            return Err(s.err(Rule::MetadataEmptyKey, rel + 4, Detail::Text("> 0"), Detail::Int(0)));
        }
        pairs.push((key, value, rel));
    }
    // Duplicate keys in O(n log n): sort by (key, position) and compare neighbours.
    let mut order: Vec<usize> = (0..pairs.len()).collect();
    order.sort_by(|&a, &b| {
        let ka = pairs.get(a).map(|p| p.0);
        let kb = pairs.get(b).map(|p| p.0);
        ka.cmp(&kb).then(a.cmp(&b))
    });
    for w in order.windows(2) {
        if let (Some(&a), Some(&b)) = (w.first(), w.get(1)) {
            if let (Some(pa), Some(pb)) = (pairs.get(a), pairs.get(b)) {
                if pa.0 == pb.0 {
                    return Err(s.err(
                        Rule::MetadataDuplicateKey,
                        pb.2,
                        Detail::Text("unique key"),
                        Detail::Int(as_u64(b)),
                    ));
                }
            }
        }
    }
    let mut meta = Metadata::default();
    let mut found = [false; 4];
    for &(key, value, _) in &pairs {
        let slot = match key {
            "tool_version" => Some((0, &mut meta.tool_version)),
            "settings" => Some((1, &mut meta.settings)),
            "input_hash" => Some((2, &mut meta.input_hash)),
            "units" => Some((3, &mut meta.units)),
            _ => None,
        };
        match slot {
            Some((i, field)) => {
                *field = String::from(value);
                if let Some(f) = found.get_mut(i) {
                    *f = true;
                }
            }
            None => meta.extra.push((String::from(key), String::from(value))),
        }
    }
    if let Some(missing) = found.iter().position(|&f| !f) {
        let name = ["tool_version", "settings", "input_hash", "units"].get(missing).copied().unwrap_or("");
        return Err(s.err(Rule::MetadataMissingKey, 0, Detail::Text(name), Detail::Text("absent")));
    }
    Ok(meta)
}

/// Reads and fully validates a `.sphb` file.
///
/// Accepts every minor version of major [`FORMAT_MAJOR`]; skips unknown section kinds
/// (after checking their bounds and checksum); checks every rule of the specification.
///
/// # Errors
///
/// The first violated rule, with its section, byte offset, expected and actual value.
///
/// # Panics
///
/// Never, for any byte string.
///
/// # Performance
///
/// Linear in the file size (metadata key uniqueness is O(k log k) in the key count).
pub fn read(bytes: &[u8]) -> Result<SphbFile> {
    let (header, entries) = read_header_and_table(bytes)?;
    let newer_minor = header.minor > FORMAT_MINOR;
    let exact = !newer_minor;
    let section = |kind: SectionKind, length_rule: Rule| -> Option<Sec<'_>> {
        let e = entries.iter().find(|e| e.kind == kind.code())?;
        // Bounds were checked by `read_header_and_table`.
        let start = usize::try_from(e.offset).ok()?;
        let end = start.checked_add(usize::try_from(e.length).ok()?)?;
        Some(Sec { data: bytes.get(start..end)?, base: e.offset, kind, length_rule, exact })
    };
    let Some(spheres_sec) = section(SectionKind::Spheres, Rule::SpheresLength) else {
        return Err(err(
            Rule::MissingSpheres,
            None,
            header.table_offset,
            Detail::Int(u64::from(SectionKind::Spheres.code())),
            Detail::Text("absent"),
        ));
    };
    let spheres = read_spheres(&spheres_sec)?;
    let n = spheres.len();
    let bones = section(SectionKind::Bones, Rule::BonesLength).map(|s| read_bones(&s)).transpose()?;
    let hierarchy =
        section(SectionKind::Hierarchy, Rule::HierarchyLength).map(|s| read_hierarchy(&s, n)).transpose()?;
    // Rule 2011 allows at most one of each pair, so at most one of these is `Some`.
    let samples = match section(SectionKind::Samples, Rule::SamplesLength) {
        Some(s) => Some(read_samples(&s, n)?),
        None => section(SectionKind::CompactSamples, Rule::CompactSamplesLength)
            .map(|s| read_compact_samples(&s, n))
            .transpose()?,
    };
    let samples = match section(SectionKind::SampleAreas, Rule::SampleAreasLength) {
        Some(s) => Some(read_sample_areas(&s, samples, &spheres)?),
        None => samples,
    };
    let albedo_sh = match section(SectionKind::AlbedoSh, Rule::ShLength) {
        Some(s) => Some(read_albedo_sh(&s, n)?),
        None => section(SectionKind::CompactAlbedoSh, Rule::CompactShLength)
            .map(|s| read_compact_albedo_sh(&s, n))
            .transpose()?,
    };
    let skin = section(SectionKind::Skin, Rule::SkinLength)
        .map(|s| read_skin(&s, n, bones.as_ref().map(Vec::len)))
        .transpose()?;
    let metadata = section(SectionKind::Metadata, Rule::MetadataLength).map(|s| read_metadata(&s)).transpose()?;
    Ok(SphbFile { spheres, hierarchy, samples, albedo_sh, skin, bones, metadata })
}

impl SphbFile {
    /// Reads and validates `bytes`; see [`read`].
    ///
    /// # Errors
    ///
    /// The first violated rule.
    pub fn from_bytes(bytes: &[u8]) -> Result<SphbFile> {
        read(bytes)
    }
}

/// Recomputes every checksum of a (possibly damaged) file in place: section CRCs whose ranges
/// lie inside the buffer, then the table CRC, then the header CRC.
///
/// Meant for tests and fuzzing (mutate a valid file, repair its checksums, reach deeper rules)
/// and for tools that patch files. Does nothing where the header or table is out of bounds.
///
/// # Panics
///
/// Never.
pub fn repair_checksums(bytes: &mut [u8]) {
    let (Some(count), Some(table_offset)) = (u32_at(bytes, 20), u64_at(bytes, 24)) else {
        return;
    };
    let Ok(table_start) = usize::try_from(table_offset) else {
        return;
    };
    let table_end = (count as usize).checked_mul(SECTION_ENTRY_SIZE).and_then(|l| table_start.checked_add(l));
    if let Some(table_end) = table_end.filter(|&e| e <= bytes.len()) {
        for i in 0..count as usize {
            let at = table_start + i * SECTION_ENTRY_SIZE;
            let (Some(off), Some(len)) = (u64_at(bytes, at + 8), u64_at(bytes, at + 16)) else {
                continue;
            };
            let range =
                usize::try_from(off).ok().zip(usize::try_from(len).ok()).and_then(|(o, l)| Some(o..o.checked_add(l)?));
            let Some(crc) = range.and_then(|r| bytes.get(r)).map(crc32fast::hash) else {
                continue;
            };
            if let Some(field) = bytes.get_mut(at + 24..at + 28) {
                field.copy_from_slice(&crc.to_le_bytes());
            }
        }
        if let Some(crc) = bytes.get(table_start..table_end).map(crc32fast::hash) {
            if let Some(field) = bytes.get_mut(40..44) {
                field.copy_from_slice(&crc.to_le_bytes());
            }
        }
    }
    if let Some(crc) = bytes.get(..HEADER_CRC_RANGE_END).map(crc32fast::hash) {
        if let Some(field) = bytes.get_mut(44..48) {
            field.copy_from_slice(&crc.to_le_bytes());
        }
    }
}
