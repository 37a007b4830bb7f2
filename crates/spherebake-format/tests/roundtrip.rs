//! Round trips, the byte layout against a hand assembly, and the version policy.

mod common;

use common::*;
use spherebake_format::{
    read, read_header_and_table, write, Rule, SectionKind, SphbFile, Sphere, FORMAT_MAJOR, FORMAT_MINOR,
};

#[test]
fn full_file_round_trips_and_rewrites_identically() {
    let file = full_file();
    let bytes = write(&file);
    let back = read(&bytes).expect("valid");
    assert_eq!(back, file);
    assert_eq!(write(&back), bytes);
    assert_eq!(bytes.len() % 16, 0);
}

#[test]
fn every_subset_of_optional_sections_round_trips() {
    let full = full_file();
    for mask in 0u32..64 {
        let mut f = SphbFile { spheres: full.spheres.clone(), ..SphbFile::default() };
        if mask & 1 != 0 {
            f.hierarchy = full.hierarchy.clone();
        }
        if mask & 2 != 0 {
            f.samples = full.samples.clone();
        }
        if mask & 4 != 0 {
            f.albedo_sh = full.albedo_sh.clone();
        }
        if mask & 8 != 0 {
            f.bones = full.bones.clone();
        }
        if mask & 16 != 0 {
            f.metadata = full.metadata.clone();
        }
        if mask & 32 != 0 && f.bones.is_some() {
            f.skin = full.skin.clone();
        }
        let bytes = write(&f);
        let back = read(&bytes).unwrap_or_else(|e| panic!("mask {mask}: {e}"));
        assert_eq!(back, f, "mask {mask}");
        assert_eq!(write(&back), bytes, "mask {mask}");
        let (header, entries) = read_header_and_table(&bytes).unwrap();
        assert_eq!(header.section_count as usize, entries.len());
        assert_eq!(entries.len(), 1 + (mask & 31).count_ones() as usize + usize::from(f.skin.is_some()));
    }
}

#[test]
fn floats_are_stored_bit_for_bit() {
    let f = SphbFile {
        spheres: vec![Sphere { center: [-0.0, f32::MIN_POSITIVE / 2.0, f32::MAX], radius: f32::MIN_POSITIVE }],
        ..SphbFile::default()
    };
    let back = read(&write(&f)).unwrap();
    let c = back.spheres[0].center;
    assert_eq!(c[0].to_bits(), (-0.0f32).to_bits());
    assert_eq!(c[1].to_bits(), (f32::MIN_POSITIVE / 2.0).to_bits());
    assert_eq!(c[2], f32::MAX);
}

/// The writer's bytes equal a file assembled by hand from the spec's byte tables.
#[test]
fn writer_matches_hand_assembled_layout() {
    let f = SphbFile {
        spheres: vec![
            Sphere { center: [1.0, 2.0, 3.0], radius: 0.5 },
            Sphere { center: [-1.0, 0.0, 0.25], radius: 2.0 },
        ],
        ..SphbFile::default()
    };
    let expected = assemble(1, 0, 64, &[(1, spheres_body(&[[1.0, 2.0, 3.0, 0.5], [-1.0, 0.0, 0.25, 2.0]]))]);
    assert_eq!(write(&f), expected);
    // Header fields at their documented offsets.
    assert_eq!(&expected[..8], b"\x89SPHB\r\n\x1a");
    assert_eq!(expected.len(), 64 + 32 + 16 + 32);
    assert_eq!(get_u32(&expected, 20), 1); // section count
    assert_eq!(get_u32(&expected, 64), 1); // kind = spheres
    assert_eq!(get_u32(&expected, 64 + 8), 96); // section offset
    assert_eq!(get_u32(&expected, 96), 2); // sphere count
    assert_eq!(f32::from_le_bytes(expected[96 + 16 + 12..96 + 32].try_into().unwrap()), 0.5);
}

#[test]
fn bones_and_metadata_layout_matches_spec_tables() {
    let bytes = write(&full_file());
    let bones = section_offset(&bytes, SectionKind::Bones);
    assert_eq!(get_u32(&bytes, bones), 2); // bone count
    assert_eq!(get_u32(&bytes, bones + 4), 9); // "hips" + "spine"
    let rec1 = bones + 16 + 80;
    assert_eq!(get_u32(&bytes, rec1), 0); // parent
    assert_eq!(get_u32(&bytes, rec1 + 4), 4); // name offset
    assert_eq!(get_u32(&bytes, rec1 + 8), 5); // name length
                                              // m[13] (column 3, row 1) is the y translation of the inverse bind matrix.
    let m13 = rec1 + 16 + 13 * 4;
    assert_eq!(f32::from_le_bytes(bytes[m13..m13 + 4].try_into().unwrap()), -1.0);
    let names = bones + 16 + 160;
    assert_eq!(&bytes[names..names + 9], b"hipsspine");
    assert_eq!(get_u32(&bytes, rec1 - 80), u32::MAX); // root has no parent

    let meta = section_offset(&bytes, SectionKind::Metadata);
    assert_eq!(get_u32(&bytes, meta), 5);
    let blob = meta + 16 + 5 * 16;
    assert_eq!(&bytes[blob..blob + 12], b"tool_version");
}

#[test]
fn newer_minor_is_accepted() {
    let mut b = write(&full_file());
    put_u16(&mut b, 10, FORMAT_MINOR + 1);
    spherebake_format::repair_checksums(&mut b);
    assert_eq!(read(&b).unwrap(), full_file());
}

#[test]
fn newer_minor_may_grow_header_and_sections() {
    // A minor newer than the reader's: an 80-byte header and a spheres section with 16 trailing
    // bytes this reader ignores.
    let newer = FORMAT_MINOR + 1;
    let mut body = spheres_body(&[[0.0, 1.0, 2.0, 3.0]]);
    body.extend_from_slice(&[7; 16]);
    let b = assemble(1, newer, 80, &[(1, body.clone())]);
    let f = read(&b).unwrap();
    assert_eq!(f.spheres, vec![Sphere { center: [0.0, 1.0, 2.0], radius: 3.0 }]);
    // The same growth in a file of a minor the reader knows (0 and 1) is refused.
    for known in 0..=FORMAT_MINOR {
        let b0 = assemble(1, known, 80, &[(1, body.clone())]);
        assert_eq!(read(&b0).unwrap_err().rule, Rule::HeaderSize);
        let b0 = assemble(1, known, 64, &[(1, body.clone())]);
        assert_eq!(read(&b0).unwrap_err().rule, Rule::SpheresLength);
    }
}

#[test]
fn other_majors_are_refused() {
    for major in [0u16, 2, 3, u16::MAX] {
        let b = assemble(major, 0, 64, &[(1, spheres_body(&[[0.0, 0.0, 0.0, 1.0]]))]);
        let e = read(&b).unwrap_err();
        assert_eq!(e.rule, Rule::UnsupportedMajor);
        assert_eq!(e.rule.id(), 1003);
        assert_eq!(e.offset, 8);
    }
    assert_eq!(FORMAT_MAJOR, 1);
}

#[test]
fn unknown_sections_are_skipped() {
    let b = assemble(1, 0, 64, &[(1, spheres_body(&[[0.0, 0.0, 0.0, 1.0]])), (0x1000, vec![1, 2, 3]), (99, vec![])]);
    let f = read(&b).unwrap();
    assert_eq!(f.spheres.len(), 1);
    assert!(f.hierarchy.is_none() && f.metadata.is_none());
    let (_, entries) = read_header_and_table(&b).unwrap();
    assert_eq!(entries.len(), 3);
    assert_eq!(entries[1].known_kind(), None);
    // Unknown sections are still bounds- and checksum-checked.
    let mut bad = b.clone();
    let unknown = entries[1].offset as usize;
    bad[unknown] ^= 1;
    assert_eq!(read(&bad).unwrap_err().rule, Rule::SectionChecksum);
}

#[test]
fn errors_display_rule_section_offset_expected_actual() {
    let b = patched(|b| {
        let s = section_offset(b, SectionKind::Spheres);
        put_f32(b, s + 16 + 16 + 12, -2.0);
    });
    let e = read(&b).unwrap_err();
    let text = e.to_string();
    assert!(text.starts_with("rule 3004 (section spheres) at byte "), "{text}");
    assert!(text.contains("found -2.0"), "{text}");
}

/// The CRC-32 variant the spec names (IEEE, zlib/PNG) has the standard check value.
#[test]
fn crc_is_the_ieee_variant() {
    assert_eq!(crc32fast::hash(b"123456789"), 0xCBF4_3926);
}
