//! Shared fixtures for the format tests: a file with every section, byte patching by the
//! spec's offsets, and an independent assembler of raw files.
#![allow(dead_code)]

use spherebake_format::{
    read_header_and_table, repair_checksums, AlbedoSh, BoneRecord, ColourSpace, Hierarchy, Metadata, NodeLists,
    SamplePoint, Samples, SectionKind, ShBasis, SkinEntry, SkinTerms, SphbFile, Sphere, UNUSED_BONE,
};

pub const IDENTITY: [f32; 16] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];

pub fn sample(direction: u8, rule: u8, position: [f32; 3], normal: [f32; 3]) -> SamplePoint {
    SamplePoint { position, normal, direction, rule }
}

/// Three spheres with every optional section.
///
/// Hierarchy: node 0 (root) has child node 1 and leaf sphere 2; node 1 has leaves 0 and 1.
/// Samples: sphere 0 has directions 0 and 5, sphere 1 none, sphere 2 direction 91.
/// Albedo SH order 2; skin with 2 slots per sphere over 2 bones ("hips" root, "spine").
pub fn full_file() -> SphbFile {
    SphbFile {
        spheres: vec![
            Sphere { center: [0.0, 0.5, 0.0], radius: 0.25 },
            Sphere { center: [0.0, 1.0, 0.1], radius: 0.3 },
            Sphere { center: [0.2, 1.5, -0.1], radius: 0.2 },
        ],
        hierarchy: Some(Hierarchy::from_lists(
            0,
            vec![
                NodeLists { center: [0.1, 1.0, 0.0], radius: 1.0, children: vec![1], leaf_children: vec![2] },
                NodeLists { center: [0.0, 0.75, 0.05], radius: 0.6, children: vec![], leaf_children: vec![0, 1] },
            ],
        )),
        samples: Some(Samples::from_per_sphere(vec![
            vec![sample(0, 1, [-0.1, 0.7, 0.0], [0.0, 1.0, 0.0]), sample(5, 3, [0.0, 0.6, 0.2], [0.0, 0.6, 0.8])],
            vec![],
            vec![sample(91, 1, [0.1, 1.5, -0.3], [0.0, 0.0, -1.0])],
        ])),
        albedo_sh: Some(AlbedoSh {
            order: 2,
            colour_space: ColourSpace::LinearRgb,
            basis: ShBasis::RealOrthonormalCs,
            coefficients: (0..12)
                .map(|i| {
                    let f = i as f32;
                    [0.5 + 0.01 * f, 0.4 - 0.01 * f, 0.3]
                })
                .collect(),
        }),
        skin: Some(SkinTerms {
            bones_per_sphere: 2,
            entries: vec![
                SkinEntry { bone: 0, q: [0.0, 0.5, 0.0], b: 1.0 },
                SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 },
                SkinEntry { bone: 0, q: [0.0, 0.5, 0.05], b: 0.5 },
                SkinEntry { bone: 1, q: [0.0, 0.0, 0.05], b: 0.5 },
                SkinEntry { bone: 1, q: [0.2, 0.5, -0.1], b: 1.0 },
                SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 },
            ],
        }),
        bones: Some(vec![
            BoneRecord { name: "hips".into(), parent: None, inverse_bind: IDENTITY },
            BoneRecord {
                name: "spine".into(),
                parent: Some(0),
                inverse_bind: {
                    let mut m = IDENTITY;
                    m[13] = -1.0; // translation y, column-major
                    m
                },
            },
        ]),
        metadata: Some(Metadata {
            tool_version: "spherebake 0.1.0".into(),
            settings: "{\"spheres\":3}".into(),
            input_hash: "00ff".into(),
            units: "metres".into(),
            extra: vec![("source".into(), "test.gltf".into())],
        }),
    }
}

/// Absolute offset of the section of `kind` in a valid (header and table) file.
pub fn section_offset(bytes: &[u8], kind: SectionKind) -> usize {
    let (_, entries) = read_header_and_table(bytes).expect("valid header and table");
    let e = entries.iter().find(|e| e.kind == kind.code()).expect("section present");
    e.offset as usize
}

/// Absolute offset of section `kind`'s table entry.
pub fn entry_offset(bytes: &[u8], kind: SectionKind) -> usize {
    let (header, entries) = read_header_and_table(bytes).expect("valid header and table");
    let i = entries.iter().position(|e| e.kind == kind.code()).expect("section present");
    header.table_offset as usize + 32 * i
}

pub fn put_u8(b: &mut [u8], at: usize, v: u8) {
    b[at] = v;
}

pub fn put_u16(b: &mut [u8], at: usize, v: u16) {
    b[at..at + 2].copy_from_slice(&v.to_le_bytes());
}

pub fn put_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

pub fn put_u64(b: &mut [u8], at: usize, v: u64) {
    b[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

pub fn put_f32(b: &mut [u8], at: usize, v: f32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

pub fn get_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Writes `full_file()`, applies `patch`, repairs the checksums.
pub fn patched(patch: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = full_file().to_bytes();
    patch(&mut b);
    repair_checksums(&mut b);
    b
}

/// Assembles a file from raw section bodies following the spec's byte tables, independently of
/// the crate's writer: header (64 bytes or `header_size`), table right after it, sections
/// 16-aligned and zero-padded.
pub fn assemble(major: u16, minor: u16, header_size: usize, sections: &[(u32, Vec<u8>)]) -> Vec<u8> {
    let table_offset = header_size;
    let mut out = vec![0u8; header_size + 32 * sections.len()];
    let mut table = Vec::new();
    for (kind, body) in sections {
        while out.len() % 16 != 0 {
            out.push(0);
        }
        let offset = out.len() as u64;
        table.extend_from_slice(&kind.to_le_bytes());
        table.extend_from_slice(&0u32.to_le_bytes());
        table.extend_from_slice(&offset.to_le_bytes());
        table.extend_from_slice(&(body.len() as u64).to_le_bytes());
        table.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
        table.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(body);
    }
    while out.len() % 16 != 0 {
        out.push(0);
    }
    out[table_offset..table_offset + table.len()].copy_from_slice(&table);
    let len = out.len() as u64;
    out[..8].copy_from_slice(&[0x89, b'S', b'P', b'H', b'B', 0x0D, 0x0A, 0x1A]);
    put_u16(&mut out, 8, major);
    put_u16(&mut out, 10, minor);
    put_u32(&mut out, 12, header_size as u32);
    put_u32(&mut out, 20, sections.len() as u32);
    put_u64(&mut out, 24, table_offset as u64);
    put_u64(&mut out, 32, len);
    let table_crc = crc32fast::hash(&table);
    put_u32(&mut out, 40, table_crc);
    let header_crc = crc32fast::hash(&out[..44]);
    put_u32(&mut out, 44, header_crc);
    out
}

/// A hand-encoded spheres section body.
pub fn spheres_body(spheres: &[[f32; 4]]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(spheres.len() as u32).to_le_bytes());
    b.extend_from_slice(&[0; 12]);
    for s in spheres {
        for v in s {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b
}
