//! Every validation rule of the specification, triggered by a hand-mutated file.
//!
//! Offsets come from the byte tables of `formats/spherebake-v1.md`, not from the reader.

mod common;

use common::*;
use spherebake_format::{
    read, repair_checksums, write, write_compact, Hierarchy, NodeLists, Rule, SectionKind, SkinEntry, SphbFile,
    UNUSED_BONE,
};
use SectionKind as K;

/// Absolute offset of section `k` in the valid fixture (patches never move sections).
/// Edits the hierarchy as per-node lists and stores it back in the flat layout.
fn edit_nodes(f: &mut SphbFile, edit: impl FnOnce(&mut Vec<NodeLists>)) {
    let h = f.hierarchy.as_mut().unwrap();
    let mut lists = h.to_lists();
    edit(&mut lists);
    *h = Hierarchy::from_lists(h.root, lists);
}

fn off(k: SectionKind) -> usize {
    section_offset(&write(&full_file()), k)
}

/// The compact encoding of the fixture (samples_q16 and albedo_sh_f16 instead of kinds 3 and 4).
fn compact() -> Vec<u8> {
    write_compact(&full_file()).expect("the fixture is encodable")
}

/// Absolute offset of section `k` in the compact fixture.
fn coff(k: SectionKind) -> usize {
    section_offset(&compact(), k)
}

/// The compact fixture with `patch` applied and the checksums repaired.
fn cpatched(patch: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = compact();
    patch(&mut b);
    repair_checksums(&mut b);
    b
}

/// `full_file()` changed by `f`, compact-encoded.
fn cmodel(f: impl FnOnce(&mut SphbFile)) -> Vec<u8> {
    let mut file = full_file();
    f(&mut file);
    write_compact(&file).expect("encodable")
}

fn model(f: impl FnOnce(&mut SphbFile)) -> Vec<u8> {
    let mut file = full_file();
    f(&mut file);
    write(&file)
}

/// (rule, file bytes, expected absolute offset of the error when the case pins one).
fn cases() -> Vec<(Rule, Vec<u8>, Option<u64>)> {
    let valid = write(&full_file());
    let mut c: Vec<(Rule, Vec<u8>, Option<u64>)> = Vec::new();

    // 1xxx header
    c.push((Rule::FileTooSmall, valid[..63].to_vec(), Some(0)));
    c.push((Rule::FileTooSmall, Vec::new(), Some(0)));
    c.push((Rule::BadMagic, patched(|b| b[1] = b'X'), Some(0)));
    c.push((Rule::UnsupportedMajor, patched(|b| put_u16(b, 8, 2)), Some(8)));
    c.push((Rule::HeaderSize, patched(|b| put_u32(b, 12, 80)), Some(12)));
    c.push((Rule::HeaderSize, patched(|b| put_u32(b, 12, 0)), Some(12)));
    // Minor 1 allows a larger header, but not one past the end of the file or unaligned.
    c.push((
        Rule::HeaderSize,
        patched(|b| {
            put_u16(b, 10, 1);
            put_u32(b, 12, 72);
        }),
        Some(12),
    ));
    c.push((
        Rule::HeaderChecksum,
        {
            let mut b = valid.clone();
            b[16] = 1; // reserved flags, covered by the header CRC
            b
        },
        Some(44),
    ));
    c.push((
        Rule::FileSize,
        {
            let mut b = valid.clone();
            b.extend_from_slice(&[0; 16]);
            b
        },
        Some(32),
    ));
    c.push((
        Rule::FileAlignment,
        {
            let mut b = valid.clone();
            b.push(0);
            let len = b.len() as u64;
            put_u64(&mut b, 32, len);
            spherebake_format::repair_checksums(&mut b);
            b
        },
        Some(32),
    ));

    // 2xxx section table
    c.push((Rule::TableOffset, patched(|b| put_u64(b, 24, 8)), Some(24)));
    c.push((Rule::TableOffset, patched(|b| put_u64(b, 24, 68)), Some(24)));
    c.push((Rule::TableBounds, patched(|b| put_u32(b, 20, 1000)), Some(20)));
    c.push((Rule::TableBounds, patched(|b| put_u64(b, 24, u64::MAX - 15)), Some(20)));
    c.push((
        Rule::TableChecksum,
        {
            let mut b = valid.clone();
            b[64 + 4] = 1; // reserved field of entry 0
            b
        },
        Some(40),
    ));
    c.push((Rule::SectionAlignment, patched(|b| put_u64(b, 64 + 8, 64 + 7 * 32 + 4)), Some(72)));
    c.push((Rule::SectionBounds, patched(|b| put_u64(b, 64 + 6 * 32 + 16, 1 << 40)), Some(64 + 6 * 32 + 8)));
    c.push((Rule::SectionBounds, patched(|b| put_u64(b, 64 + 8, 48)), Some(72)));
    c.push((Rule::SectionBounds, patched(|b| put_u64(b, 64 + 8, u64::MAX - 15)), Some(72)));
    c.push((
        Rule::SectionOrder,
        patched(|b| {
            let first = u64::from(get_u32(b, 64 + 8));
            put_u64(b, 64 + 32 + 8, first);
        }),
        Some(64 + 32 + 8),
    ));
    c.push((Rule::DuplicateSection, patched(|b| put_u32(b, 64 + 32, 1)), Some(96)));
    c.push((
        Rule::SectionChecksum,
        {
            let mut b = valid.clone();
            let s = off(K::Spheres);
            b[s + 20] ^= 0x40;
            b
        },
        Some(64 + 24),
    ));
    c.push((Rule::MissingSpheres, patched(|b| put_u32(b, 64, 100)), Some(64)));
    c.push((
        Rule::NonZeroPadding,
        patched(|b| {
            // The bones section is 16 + 2·80 + 9 = 185 bytes, followed by 7 padding bytes.
            let at = off(K::Bones) + 185;
            b[at] = 1;
        }),
        None,
    ));
    c.push((
        Rule::NonZeroPadding,
        patched(|b| {
            let n = b.len();
            b[n - 1] = 9; // the padding after the last section
        }),
        Some(valid.len() as u64 - 1),
    ));

    // 3xxx spheres
    c.push((Rule::SpheresLength, patched(|b| put_u32(b, off(K::Spheres), 4)), None));
    c.push((Rule::SpheresEmpty, write(&SphbFile::default()), None));
    c.push((
        Rule::SphereCentre,
        patched(|b| put_f32(b, off(K::Spheres) + 32 + 4, f32::NAN)),
        Some(off(K::Spheres) as u64 + 36),
    ));
    for r in [0.0, -1.0, f32::INFINITY, f32::NAN, -0.0] {
        c.push((
            Rule::SphereRadius,
            patched(|b| put_f32(b, off(K::Spheres) + 48 + 12, r)),
            Some(off(K::Spheres) as u64 + 60),
        ));
    }

    // 4xxx hierarchy (node i at +16+32i; child array at +80, leaf array at +84: [2, 0, 1])
    c.push((Rule::HierarchyLength, patched(|b| put_u32(b, off(K::Hierarchy), 3)), None));
    c.push((Rule::HierarchyEmpty, model(|f| f.hierarchy.as_mut().unwrap().nodes.clear()), None));
    c.push((Rule::HierarchyRoot, patched(|b| put_u32(b, off(K::Hierarchy) + 4, 2)), None));
    c.push((
        Rule::NodeCentre,
        patched(|b| put_f32(b, off(K::Hierarchy) + 48 + 8, f32::NEG_INFINITY)),
        Some(off(K::Hierarchy) as u64 + 56),
    ));
    c.push((Rule::NodeRadius, patched(|b| put_f32(b, off(K::Hierarchy) + 16 + 12, -1.0)), None));
    c.push((Rule::NodeChildRange, patched(|b| put_u32(b, off(K::Hierarchy) + 16 + 16, 1)), None));
    c.push((Rule::NodeLeafRange, patched(|b| put_u32(b, off(K::Hierarchy) + 48 + 28, 3)), None));
    c.push((Rule::ChildIndex, patched(|b| put_u32(b, off(K::Hierarchy) + 80, 2)), None));
    c.push((Rule::LeafIndex, patched(|b| put_u32(b, off(K::Hierarchy) + 84, 3)), None));
    // The root lists itself as its child: a cycle.
    c.push((Rule::NodeRevisited, patched(|b| put_u32(b, off(K::Hierarchy) + 80, 0)), None));
    c.push((
        Rule::NodeUnreachable,
        model(|f| {
            edit_nodes(f, |nodes| {
                nodes.push(NodeLists { center: [0.0; 3], radius: 1.0, children: vec![1], leaf_children: vec![] })
            })
        }),
        None,
    ));
    c.push((Rule::LeafRevisited, patched(|b| put_u32(b, off(K::Hierarchy) + 92, 2)), None));
    c.push((Rule::LeafUnreachable, model(|f| edit_nodes(f, |nodes| nodes[0].leaf_children.clear())), None));
    c.push((
        Rule::NodeEmpty,
        model(|f| {
            edit_nodes(f, |nodes| {
                nodes[0].children.push(2);
                nodes.push(NodeLists { center: [0.0; 3], radius: 1.0, children: vec![], leaf_children: vec![] });
            });
        }),
        None,
    ));

    // 5xxx samples (offsets at +16: [0, 2, 2, 3]; sample j at +32+32j)
    c.push((Rule::SamplesLength, patched(|b| put_u32(b, off(K::Samples) + 4, 4)), None));
    c.push((
        Rule::SamplesSphereCount,
        model(|f| {
            let s = f.samples.as_mut().unwrap();
            s.offsets.pop();
            s.points.truncate(*s.offsets.last().unwrap() as usize);
        }),
        Some(off(K::Samples) as u64),
    ));
    c.push((Rule::SampleOffsets, patched(|b| put_u32(b, off(K::Samples) + 16, 1)), None));
    c.push((Rule::SampleOffsets, patched(|b| put_u32(b, off(K::Samples) + 24, 1)), None));
    c.push((Rule::SampleOffsets, patched(|b| put_u32(b, off(K::Samples) + 28, 2)), None));
    c.push((
        Rule::SamplePosition,
        patched(|b| put_f32(b, off(K::Samples) + 64 + 8, f32::NAN)),
        Some(off(K::Samples) as u64 + 72),
    ));
    c.push((Rule::SampleNormal, patched(|b| put_f32(b, off(K::Samples) + 32 + 12, 1.0)), None));
    c.push((Rule::SampleNormal, patched(|b| put_f32(b, off(K::Samples) + 32 + 16, f32::NAN)), None));
    c.push((
        Rule::SampleDirection,
        patched(|b| put_u8(b, off(K::Samples) + 96 + 24, 92)),
        Some(off(K::Samples) as u64 + 120),
    ));
    for r in [0u8, 4, 255] {
        c.push((Rule::SampleRule, patched(|b| put_u8(b, off(K::Samples) + 32 + 25, r)), None));
    }
    c.push((Rule::SampleDirectionOrder, patched(|b| put_u8(b, off(K::Samples) + 64 + 24, 0)), None));

    // 5xxx compact samples (spec §7.1; 3 spheres, 3 samples: offsets at +16 [0, 2, 2, 3],
    // boxes at +32 (24 bytes each: origin, step), records at +104 (12 bytes: q[3], oct[2],
    // direction, rule)).
    let cs = coff(K::CompactSamples);
    c.push((Rule::CompactSamplesLength, cpatched(|b| put_u32(b, cs + 4, 4)), Some(cs as u64)));
    c.push((Rule::CompactSamplesLength, cpatched(|b| put_u32(b, cs, u32::MAX)), Some(cs as u64)));
    // Truncated: the table says the section ends 12 bytes early (one record short).
    c.push((
        Rule::CompactSamplesLength,
        cpatched(|b| {
            let e = entry_offset(b, K::CompactSamples);
            let (start, len) = (get_u32(b, e + 8) as usize, get_u32(b, e + 16) as usize);
            put_u64(b, e + 16, (len - 12) as u64);
            b[start + len - 12..start + len].fill(0); // the cut-off bytes become zero padding
        }),
        Some(cs as u64),
    ));
    c.push((
        Rule::SamplesSphereCount,
        cmodel(|f| {
            let s = f.samples.as_mut().unwrap();
            s.offsets.pop();
            s.points.truncate(*s.offsets.last().unwrap() as usize);
        }),
        Some(cs as u64),
    ));
    c.push((Rule::SampleOffsets, cpatched(|b| put_u32(b, cs + 16, 1)), Some(cs as u64 + 16)));
    c.push((Rule::SampleOffsets, cpatched(|b| put_u32(b, cs + 24, 1)), Some(cs as u64 + 24)));
    c.push((Rule::SampleBox, cpatched(|b| put_f32(b, cs + 32 + 24 + 4, f32::NAN)), Some(cs as u64 + 56)));
    c.push((Rule::SampleBox, cpatched(|b| put_f32(b, cs + 32 + 12, -1.0)), Some(cs as u64 + 32)));
    c.push((Rule::SampleBox, cpatched(|b| put_f32(b, cs + 32 + 16, f32::INFINITY)), Some(cs as u64 + 32)));
    // Finite origin and step whose far corner origin + 65535 · step overflows f32.
    c.push((
        Rule::SampleBox,
        cpatched(|b| {
            put_f32(b, cs + 32, 3.0e38);
            put_f32(b, cs + 32 + 12, 1.0e34);
        }),
        Some(cs as u64 + 32),
    ));
    c.push((
        Rule::SampleOctNormal,
        cpatched(|b| put_u16(b, cs + 104 + 12 + 8, 0x8000)),
        Some(cs as u64 + 104 + 12 + 8),
    ));
    c.push((Rule::SampleDirection, cpatched(|b| put_u8(b, cs + 104 + 24 + 10, 92)), Some(cs as u64 + 138)));
    c.push((Rule::SampleRule, cpatched(|b| put_u8(b, cs + 104 + 11, 0)), Some(cs as u64 + 115)));
    c.push((Rule::SampleDirectionOrder, cpatched(|b| put_u8(b, cs + 104 + 12 + 10, 0)), Some(cs as u64 + 126)));

    // 5012–5014 sample areas (spec §7.2; kind 10, last section; the fixture has 3 samples:
    // count at +0, areas at +16).
    let with_areas = |f: &mut SphbFile| f.samples.as_mut().unwrap().areas = Some(vec![0.01, 0.02, 0.03]);
    let area_bytes = model(with_areas);
    read(&area_bytes).expect("the fixture with areas is valid");
    let ao = section_offset(&area_bytes, K::SampleAreas);
    let apatched = |patch: &dyn Fn(&mut Vec<u8>)| {
        let mut b = area_bytes.clone();
        patch(&mut b);
        repair_checksums(&mut b);
        b
    };
    c.push((Rule::SampleAreasLength, apatched(&|b| put_u32(b, ao, 4)), Some(ao as u64)));
    c.push((Rule::SampleAreasLength, apatched(&|b| put_u32(b, ao, u32::MAX)), Some(ao as u64)));
    c.push((
        Rule::SampleAreasCount,
        model(|f| f.samples.as_mut().unwrap().areas = Some(vec![0.01, 0.02])),
        Some(section_offset(&model(|f| f.samples.as_mut().unwrap().areas = Some(vec![0.01, 0.02])), K::SampleAreas)
            as u64),
    ));
    // Areas without samples: the samples entry relabelled as an unknown kind (skipped).
    c.push((
        Rule::SampleAreasCount,
        apatched(&|b| {
            let e = entry_offset(b, K::Samples);
            put_u32(b, e, 77);
        }),
        Some(ao as u64),
    ));
    c.push((Rule::SampleArea, apatched(&|b| put_f32(b, ao + 16 + 4, -0.5)), Some(ao as u64 + 20)));
    c.push((Rule::SampleArea, apatched(&|b| put_f32(b, ao + 16 + 8, f32::NAN)), Some(ao as u64 + 24)));
    c.push((Rule::SampleArea, apatched(&|b| put_f32(b, ao + 16, f32::INFINITY)), Some(ao as u64 + 16)));
    c.push((Rule::SampleAreasEncoding, apatched(&|b| put_u8(b, ao + 4, 2)), Some(ao as u64 + 4)));
    // Encoding 1 (f16 per r², 2 bytes each) with the f32 section's 4-byte records: wrong length.
    c.push((Rule::SampleAreasLength, apatched(&|b| put_u8(b, ao + 4, 1)), Some(ao as u64)));
    // The compact file's areas are encoding 1: a negative f16 and an f16 infinity.
    let compact_areas = write_compact(&{
        let mut f = full_file();
        with_areas(&mut f);
        f
    })
    .unwrap();
    let cao = section_offset(&compact_areas, K::SampleAreas);
    assert_eq!(compact_areas[cao + 4], 1, "the compact writer uses encoding 1 here");
    for (at, bits) in [(cao + 16 + 2, 0xBC00u16), (cao + 16 + 4, 0x7C00)] {
        let mut b = compact_areas.clone();
        put_u16(&mut b, at, bits);
        repair_checksums(&mut b);
        c.push((Rule::SampleArea, b, Some(at as u64)));
    }

    // 2011: lossless and compact samples (or SH) in one file.
    // The skin (bones) entry relabelled as lossless samples (SH): the table then lists kinds 3
    // and 8 (4 and 9); the error points at the second one's kind field.
    for (relabel, lossless, compact_kind) in
        [(K::Skin, K::Samples, K::CompactSamples), (K::Bones, K::AlbedoSh, K::CompactAlbedoSh)]
    {
        let at = entry_offset(&compact(), compact_kind) as u64;
        c.push((
            Rule::SectionConflict,
            cpatched(|b| {
                let e = entry_offset(b, relabel);
                put_u32(b, e, lossless.code());
            }),
            Some(at),
        ));
    }

    // 6xxx compact albedo SH (order 2, 3 spheres: 12 coefficients of 3 × f16 at +16 + 6i)
    let csh = coff(K::CompactAlbedoSh);
    c.push((Rule::CompactShLength, cpatched(|b| put_u8(b, csh + 4, 3)), Some(csh as u64)));
    c.push((
        Rule::CompactShLength,
        cpatched(|b| {
            let e = entry_offset(b, K::CompactAlbedoSh);
            let start = get_u32(b, e + 8) as usize;
            put_u64(b, e + 16, 16 + 6 * 12 - 2);
            b[start + 16 + 6 * 12 - 2..start + 16 + 6 * 12].fill(0);
        }),
        Some(csh as u64),
    ));
    c.push((Rule::ShSphereCount, cmodel(|f| f.albedo_sh.as_mut().unwrap().coefficients.truncate(8)), None));
    c.push((Rule::ShOrder, cpatched(|b| put_u8(b, csh + 4, 9)), None));
    c.push((Rule::ShColourSpace, cpatched(|b| put_u8(b, csh + 5, 1)), None));
    c.push((Rule::ShBasis, cpatched(|b| put_u8(b, csh + 6, 1)), None));
    for bits in [0x7c00u16, 0xfc00, 0x7e00] {
        c.push((Rule::ShCoefficient, cpatched(|b| put_u16(b, csh + 16 + 6 * 7 + 2, bits)), Some(csh as u64 + 60)));
    }

    // 6xxx albedo SH
    c.push((Rule::ShLength, patched(|b| put_u8(b, off(K::AlbedoSh) + 4, 3)), None));
    c.push((Rule::ShSphereCount, model(|f| f.albedo_sh.as_mut().unwrap().coefficients.truncate(8)), None));
    for o in [0u8, 9] {
        c.push((Rule::ShOrder, patched(|b| put_u8(b, off(K::AlbedoSh) + 4, o)), None));
    }
    c.push((Rule::ShColourSpace, patched(|b| put_u8(b, off(K::AlbedoSh) + 5, 1)), None));
    c.push((Rule::ShBasis, patched(|b| put_u8(b, off(K::AlbedoSh) + 6, 1)), None));
    c.push((
        Rule::ShCoefficient,
        patched(|b| put_f32(b, off(K::AlbedoSh) + 16 + 12 * 11 + 8, f32::INFINITY)),
        Some(off(K::AlbedoSh) as u64 + 16 + 132 + 8),
    ));

    // 7xxx skin (entry i at +16+20i; entry 1 is an unused slot)
    c.push((Rule::SkinLength, patched(|b| put_u32(b, off(K::Skin) + 4, 3)), None));
    c.push((Rule::SkinSphereCount, model(|f| f.skin.as_mut().unwrap().entries.truncate(4)), None));
    for k in [0u32, 65] {
        c.push((Rule::SkinBonesPerSphere, patched(|b| put_u32(b, off(K::Skin) + 4, k)), None));
    }
    c.push((Rule::SkinWithoutBones, model(|f| f.bones = None), None));
    c.push((Rule::SkinBoneIndex, patched(|b| put_u32(b, off(K::Skin) + 16 + 40, 2)), None));
    c.push((Rule::SkinTerm, patched(|b| put_f32(b, off(K::Skin) + 16 + 16, f32::NAN)), Some(off(K::Skin) as u64 + 32)));
    c.push((
        Rule::SkinUnusedSlot,
        model(|f| f.skin.as_mut().unwrap().entries[1] = SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 1.0 }),
        None,
    ));

    // 8xxx bones (record i at +16+80i: parent, name offset, name length, reserved, matrix)
    c.push((Rule::BonesLength, patched(|b| put_u32(b, off(K::Bones) + 4, 10)), None));
    c.push((Rule::BoneNameRange, patched(|b| put_u32(b, off(K::Bones) + 96 + 8, 6)), None));
    c.push((Rule::BoneNameRange, patched(|b| put_u32(b, off(K::Bones) + 96 + 4, u32::MAX)), None));
    c.push((Rule::BoneNameUtf8, patched(|b| put_u8(b, off(K::Bones) + 176 + 1, 0xFF)), None));
    c.push((Rule::BoneParent, patched(|b| put_u32(b, off(K::Bones) + 96, 2)), None));
    c.push((Rule::BoneCycle, patched(|b| put_u32(b, off(K::Bones) + 16, 1)), None));
    c.push((Rule::BoneCycle, patched(|b| put_u32(b, off(K::Bones) + 96, 1)), None));
    c.push((
        Rule::BoneMatrix,
        patched(|b| put_f32(b, off(K::Bones) + 96 + 16 + 60, f32::NAN)),
        Some(off(K::Bones) as u64 + 96 + 76),
    ));

    // 9xxx metadata (entry i at +16+16i; strings at +96, entry 3 is "units")
    c.push((Rule::MetadataLength, patched(|b| put_u32(b, off(K::Metadata) + 4, 1)), None));
    c.push((
        Rule::MetadataStringRange,
        patched(|b| put_u32(b, off(K::Metadata) + 16 + 4, 1000)),
        Some(off(K::Metadata) as u64 + 16),
    ));
    c.push((Rule::MetadataStringRange, patched(|b| put_u32(b, off(K::Metadata) + 16 + 8, u32::MAX)), None));
    c.push((Rule::MetadataUtf8, patched(|b| put_u8(b, off(K::Metadata) + 96, 0xC3)), None));
    c.push((
        Rule::MetadataEmptyKey,
        model(|f| f.metadata.as_mut().unwrap().extra.push((String::new(), "x".into()))),
        None,
    ));
    c.push((
        Rule::MetadataDuplicateKey,
        model(|f| f.metadata.as_mut().unwrap().extra.push(("units".into(), "feet".into()))),
        Some(off(K::Metadata) as u64 + 16 + 16 * 5),
    ));
    c.push((
        Rule::MetadataMissingKey,
        patched(|b| {
            let m = off(K::Metadata);
            let key = m + 96 + get_u32(b, m + 16 + 48) as usize;
            assert_eq!(&b[key..key + 5], b"units");
            b[key] = b'x';
        }),
        None,
    ));
    c
}

/// Rule 5014 reads "finite and ≥ 0" the same way in both encodings: −0 is 0 (valid), the
/// smallest negative value of each is refused.
#[test]
fn minus_zero_areas_are_valid_in_both_encodings() {
    let mut f = full_file();
    f.samples.as_mut().unwrap().areas = Some(vec![0.01, 0.02, 0.03]);
    let lossless = write(&f);
    let compact = write_compact(&f).unwrap();
    let (lo, co) = (section_offset(&lossless, K::SampleAreas), section_offset(&compact, K::SampleAreas));
    assert_eq!((lossless[lo + 4], compact[co + 4]), (0, 1), "f32 and f16 encodings");
    let patched = |bytes: &[u8], patch: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.to_vec();
        patch(&mut b);
        repair_checksums(&mut b);
        read(&b)
    };
    let zero_f32 = patched(&lossless, &|b| put_f32(b, lo + 16 + 4, -0.0)).expect("f32 -0 is 0");
    let zero_f16 = patched(&compact, &|b| put_u16(b, co + 16 + 2, 0x8000)).expect("f16 -0 is 0");
    for file in [zero_f32, zero_f16] {
        assert_eq!(file.samples.unwrap().areas.unwrap()[1], 0.0);
    }
    for (bytes, patch) in [
        (&lossless, &(|b: &mut Vec<u8>| put_f32(b, lo + 16 + 4, -f32::from_bits(1))) as &dyn Fn(&mut Vec<u8>)),
        (&compact, &|b: &mut Vec<u8>| put_u16(b, co + 16 + 2, 0x8001)),
    ] {
        let e = patched(bytes, patch).expect_err("a negative area");
        assert_eq!(e.rule, Rule::SampleArea);
    }
}

#[test]
fn every_case_reports_its_rule() {
    for (i, (rule, bytes, offset)) in cases().into_iter().enumerate() {
        let e = read(&bytes).expect_err(&format!("case {i} ({rule:?}) must fail"));
        assert_eq!(e.rule, rule, "case {i}: {e}");
        if let Some(off) = offset {
            assert_eq!(e.offset, off, "case {i}: {e}");
        }
        // Section attribution follows the rule's thousands digit.
        let group = rule.id() / 1000;
        match e.section {
            None => assert!(group <= 2, "case {i}: {e}"),
            // The sample areas belong to the samples (5xxx) without being a second samples
            // encoding (rule 2011 counts families).
            Some(K::SampleAreas) => assert_eq!(group, 5, "case {i}: {e}"),
            Some(k) => assert_eq!(u32::from(group) - 2, k.family().code(), "case {i}: {e}"),
        }
    }
}

#[test]
fn every_rule_has_a_case() {
    let cases = cases();
    for rule in Rule::ALL {
        assert!(cases.iter().any(|(r, _, _)| r == rule), "rule {} ({rule:?}) has no test case", rule.id());
    }
}

#[test]
fn rule_ids_are_unique_grouped_and_ascending() {
    let ids: Vec<u16> = Rule::ALL.iter().map(|r| r.id()).collect();
    assert!(ids.windows(2).all(|w| w[0] < w[1]));
    assert!(ids.iter().all(|&id| (1001..=9999).contains(&id)));
    assert_eq!(Rule::SectionChecksum.id(), 2008);
}

#[test]
fn the_valid_fixture_passes() {
    read(&write(&full_file())).unwrap();
}

#[test]
fn spec_lists_every_rule() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/spherebake-v1.md");
    let spec = std::fs::read_to_string(path).expect("formats/spherebake-v1.md exists");
    for rule in Rule::ALL {
        let line = format!("| {} | {} |", rule.id(), rule.message());
        assert!(spec.contains(&line), "spec lacks the row `{line}`");
    }
}
