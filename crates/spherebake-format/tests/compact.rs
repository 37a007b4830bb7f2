//! The compact sections (format minor 1): error bounds of the quantisation primitives derived
//! analytically (spec §7.1, §8.1), the round trip through `write_compact` + `read`, what a v1.0
//! reader sees, determinism, encoder refusals, and mutated compact files.

mod common;

use common::*;
use proptest::prelude::*;
use spherebake_format::quant::{
    f16_from_f32, f16_is_finite, f32_from_f16, oct_decode, oct_encode, SampleBox, F16_MAX, OCT_MAX, Q16_MAX,
};
use spherebake_format::{
    read, read_header_and_table, repair_checksums, write, write_compact, EncodeError, SamplePoint, SectionKind,
    SphbFile,
};

/// Octahedral chord bound: √18 · h with h = 1/(2·32767) (spec §7.1), plus 1e-6 for the f32
/// rounding of the three decoded components and of the input.
fn oct_bound() -> f64 {
    18f64.sqrt() / (2.0 * f64::from(OCT_MAX)) + 1e-6
}

fn chord(a: [f32; 3], b: [f64; 3]) -> f64 {
    let d: f64 = (0..3).map(|k| (f64::from(a[k]) - b[k]).powi(2)).sum();
    d.sqrt()
}

fn unit(n: [f32; 3]) -> [f64; 3] {
    let l = n.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>().sqrt();
    n.map(|x| f64::from(x) / l)
}

#[test]
fn f16_decodes_every_finite_pattern_and_re_encodes_it_exactly() {
    let mut finite = 0;
    for bits in 0..=u16::MAX {
        let x = f32_from_f16(bits);
        assert_eq!(f16_is_finite(bits), x.is_finite(), "{bits:#06x}");
        if x.is_finite() {
            finite += 1;
            assert_eq!(f16_from_f32(x), Some(bits), "{bits:#06x} decodes to {x:?}");
        }
    }
    // 2 × 31 exponents × 1024 mantissas.
    assert_eq!(finite, 2 * 31 * 1024);
    // Reference values from the IEEE 754 definition.
    assert_eq!(f32_from_f16(0x3c00), 1.0);
    assert_eq!(f32_from_f16(0xc000), -2.0);
    assert_eq!(f32_from_f16(0x7bff), 65504.0);
    assert_eq!(f32_from_f16(0x0001), 2f32.powi(-24));
    assert_eq!(f32_from_f16(0x0400), 2f32.powi(-14));
    assert_eq!(f32_from_f16(0x3555), 0.333_251_95);
    assert_eq!(F16_MAX, 65504.0);
}

#[test]
fn f16_refuses_what_would_round_to_infinity() {
    assert_eq!(f16_from_f32(65504.0), Some(0x7bff));
    assert_eq!(f16_from_f32(65519.996), Some(0x7bff));
    assert_eq!(f16_from_f32(65520.0), None);
    assert_eq!(f16_from_f32(-1.0e6), None);
    assert_eq!(f16_from_f32(f32::NAN), None);
    assert_eq!(f16_from_f32(f32::INFINITY), None);
    // Ties go to the even mantissa: 1 + 2^-11 lies halfway between 1 and 1 + 2^-10.
    assert_eq!(f16_from_f32(1.0 + 2f32.powi(-11)), Some(0x3c00));
    assert_eq!(f16_from_f32(1.0 + 3.0 * 2f32.powi(-11)), Some(0x3c02));
}

proptest! {
    #[test]
    fn f16_is_nearest_and_within_its_relative_bound(x in -65000.0f32..65000.0) {
        let bits = f16_from_f32(x).unwrap();
        let y = f32_from_f16(bits);
        let err = (f64::from(y) - f64::from(x)).abs();
        // Spec §8.1: 2^-11 relative for normal f16 values, 2^-25 absolute below 2^-14.
        let bound = if x.abs() >= 2f32.powi(-14) { f64::from(x.abs()) * 2f64.powi(-11) } else { 2f64.powi(-25) };
        prop_assert!(err <= bound, "{x} -> {y}, error {err} > {bound}");
        // Nearest: neither neighbouring f16 is closer.
        for nb in [bits.wrapping_sub(1), bits.wrapping_add(1)] {
            let z = f32_from_f16(nb);
            if z.is_finite() && (nb & 0x7fff) != 0x7fff {
                prop_assert!((f64::from(z) - f64::from(x)).abs() >= err);
            }
        }
    }

    #[test]
    fn f16_small_values_within_the_subnormal_bound(x in -1.0e-4f32..1.0e-4) {
        let y = f32_from_f16(f16_from_f32(x).unwrap());
        let bound = (f64::from(x.abs()) * 2f64.powi(-11)).max(2f64.powi(-25));
        prop_assert!((f64::from(y) - f64::from(x)).abs() <= bound);
    }

    #[test]
    fn octahedral_round_trip_within_the_chord_bound(x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0, scale in 0.5f32..2.0) {
        prop_assume!(x * x + y * y + z * z > 1e-6);
        let n = [x * scale, y * scale, z * scale];
        let q = oct_encode(n).unwrap();
        prop_assert!(q.iter().all(|&c| (-OCT_MAX..=OCT_MAX).contains(&c)));
        let d = oct_decode(q);
        let len = d.iter().map(|&c| f64::from(c).powi(2)).sum::<f64>().sqrt();
        prop_assert!((len - 1.0).abs() < 1e-6);
        let e = chord(d, unit(n));
        prop_assert!(e <= oct_bound(), "{n:?} -> {q:?} -> {d:?}: chord {e}");
    }

    #[test]
    fn positions_within_half_a_step(
        lo in proptest::array::uniform3(-100.0f32..100.0),
        span in proptest::array::uniform3(0.0f32..10.0),
        t in proptest::collection::vec(proptest::array::uniform3(0.0f32..=1.0), 1..40),
    ) {
        let pts: Vec<[f32; 3]> = t.iter().map(|t| [0, 1, 2].map(|k| lo[k] + span[k] * t[k])).collect();
        let b = SampleBox::enclosing(pts.iter().copied()).unwrap();
        prop_assert!(b.is_valid());
        for p in &pts {
            let d = b.decode(b.quantise(*p));
            for k in 0..3 {
                // Spec §7.1: step/2, plus half an ulp of the f32 result (2^-24 relative).
                let bound = 0.5 * f64::from(b.step[k]) + f64::from(d[k].abs()) * 2f64.powi(-24) + 1e-30;
                let err = (f64::from(d[k]) - f64::from(p[k])).abs();
                prop_assert!(err <= bound, "axis {k}: {} -> {}, error {err} > {bound}", p[k], d[k]);
            }
        }
        // The box spans the points: step 0 and the maximum at step 65535 are covered.
        for k in 0..3 {
            let hi = pts.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max);
            prop_assert!(f64::from(b.origin[k]) + f64::from(b.step[k]) * f64::from(Q16_MAX) >= f64::from(hi));
        }
    }
}

#[test]
fn octahedral_axes_and_diagonals_are_exact() {
    for n in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]] {
        assert_eq!(oct_decode(oct_encode(n).unwrap()), n);
    }
    assert_eq!(oct_encode([0.0, 0.0, 1.0]), Some([0, 0]));
    assert_eq!(oct_encode([1.0, 0.0, 0.0]), Some([OCT_MAX, 0]));
    assert_eq!(oct_encode([0.0, 0.0, -1.0]), Some([OCT_MAX, OCT_MAX]));
    assert_eq!(oct_encode([0.0; 3]), None);
    assert_eq!(oct_encode([f32::NAN, 0.0, 1.0]), None);
}

fn all_samples(f: &SphbFile) -> Vec<(usize, SamplePoint)> {
    let s = f.samples.as_ref().unwrap();
    s.per_sphere().enumerate().flat_map(|(i, v)| v.iter().map(move |p| (i, *p))).collect()
}

#[test]
fn compact_file_round_trips_within_the_bounds() {
    let file = full_file();
    let bytes = write_compact(&file).unwrap();
    let (header, entries) = read_header_and_table(&bytes).unwrap();
    assert_eq!(header.minor, 1);
    let kinds: Vec<u32> = entries.iter().map(|e| e.kind).collect();
    assert_eq!(kinds, vec![1, 2, 5, 6, 7, 8, 9]);
    // Section lengths by the spec's formulas: N = 3, S = 3, order 2.
    let len = |k: SectionKind| entries.iter().find(|e| e.kind == k.code()).unwrap().length;
    assert_eq!(len(SectionKind::CompactSamples), 16 + 16 + 24 * 3 + 12 * 3);
    assert_eq!(len(SectionKind::CompactAlbedoSh), 16 + 6 * 3 * 4);

    let back = read(&bytes).unwrap();
    // Everything but samples and SH is bit-identical.
    assert_eq!(back.spheres, file.spheres);
    assert_eq!(back.hierarchy, file.hierarchy);
    assert_eq!(back.skin, file.skin);
    assert_eq!(back.bones, file.bones);
    assert_eq!(back.metadata, file.metadata);
    let (a, b) = (all_samples(&file), all_samples(&back));
    assert_eq!(a.len(), b.len());
    for ((si, p), (sj, q)) in a.iter().zip(&b) {
        assert_eq!(si, sj);
        assert_eq!((p.direction, p.rule), (q.direction, q.rule));
        assert!(chord(q.normal, unit(p.normal)) <= oct_bound());
        // The fixture's coordinates lie within 0.6 of each other per sphere: step ≤ 0.6/65535.
        for k in 0..3 {
            assert!((q.position[k] - p.position[k]).abs() <= 0.5 * 0.6 / 65535.0 + 1e-7);
        }
    }
    let (sa, sb) = (file.albedo_sh.as_ref().unwrap(), back.albedo_sh.as_ref().unwrap());
    assert_eq!((sa.order, sa.colour_space, sa.basis), (sb.order, sb.colour_space, sb.basis));
    for (x, y) in sa.coefficients.iter().flatten().zip(sb.coefficients.iter().flatten()) {
        assert!((x - y).abs() <= x.abs() * 2f32.powi(-11));
    }
}

#[test]
fn compact_writing_is_deterministic_and_smaller() {
    let file = full_file();
    let a = write_compact(&file).unwrap();
    assert_eq!(a, write_compact(&file.clone()).unwrap());
    assert!(a.len() < write(&file).len());
    // A file without samples or SH has no compact section but is still written as minor 1.
    let mut plain = file.clone();
    plain.samples = None;
    plain.albedo_sh = None;
    let b = write_compact(&plain).unwrap();
    assert_eq!(read(&b).unwrap(), plain);
    // The lossless writer stays at minor 0.
    assert_eq!(read_header_and_table(&write(&file)).unwrap().0.minor, 0);
}

#[test]
fn a_v1_0_reader_sees_a_valid_file_without_samples_and_albedo() {
    // A v1.0 reader does not know kinds 8 and 9: relabelling them as unknown kinds (here 0x100
    // and 0x101) shows what it reads, with the same skipping code.
    let mut b = write_compact(&full_file()).unwrap();
    let (header, entries) = read_header_and_table(&b).unwrap();
    for (i, e) in entries.iter().enumerate() {
        if e.kind == 8 || e.kind == 9 {
            put_u32(&mut b, header.table_offset as usize + 32 * i, 0x100 + e.kind - 8);
        }
    }
    repair_checksums(&mut b);
    let old_view = read(&b).unwrap();
    let mut expected = full_file();
    expected.samples = None;
    expected.albedo_sh = None;
    assert_eq!(old_view, expected);
}

#[test]
fn unencodable_values_are_refused() {
    let mut f = full_file();
    let s = f.samples.as_mut().unwrap();
    let at = s.range_of(2).start;
    s.points[at].position[1] = f32::NAN;
    assert_eq!(write_compact(&f), Err(EncodeError::SamplePosition { sphere: 2 }));
    let mut f = full_file();
    f.samples.as_mut().unwrap().points[1].normal = [0.0; 3];
    assert_eq!(write_compact(&f), Err(EncodeError::SampleNormal { sphere: 0, sample: 1 }));
    let mut f = full_file();
    f.albedo_sh.as_mut().unwrap().coefficients[5][2] = 1.0e5;
    let e = write_compact(&f).unwrap_err();
    assert_eq!(e, EncodeError::ShCoefficient { index: 5, value: 1.0e5 });
    assert!(e.to_string().contains("f16"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]
    /// Mutated compact files (any byte, then checksums repaired so the section rules are reached)
    /// give `Ok` or a rule error, never a panic; when `Ok`, every decoded normal is unit length.
    #[test]
    fn mutated_compact_files_never_panic(at in 0usize..2048, value in any::<u8>(), cut in 0usize..64) {
        let mut b = write_compact(&full_file()).unwrap();
        let i = at % b.len();
        b[i] = value;
        if cut > 48 {
            b.truncate(b.len() - (cut - 48));
        }
        repair_checksums(&mut b);
        if let Ok(f) = read(&b) {
            if let Some(s) = &f.samples {
                for p in &s.points {
                    let l: f32 = p.normal.iter().map(|c| c * c).sum();
                    prop_assert!((l - 1.0).abs() < 1e-5);
                    prop_assert!(p.position.iter().all(|c| c.is_finite()));
                }
            }
        }
    }
}

/// Sample areas (format minor 2, spec §7.2): the lossless writer carries them bit for bit
/// (encoding 0, f32), the compact one as f16 of area / r² (encoding 1) within the f16 rounding
/// (relative 2⁻¹¹ for normal ratios, 2⁻²⁵ r² absolute below); both stamp minor 2.
#[test]
fn sample_areas_round_trip_in_both_encodings_and_stamp_minor_2() {
    let mut file = full_file();
    // Spheres 0 (r = 0.25, two samples) and 2 (r = 0.2, one sample): ratios 1.9, 4.8e-6, 0.
    let areas = vec![0.118_75f32, 3.0e-7, 0.0];
    file.samples.as_mut().unwrap().areas = Some(areas.clone());
    let radius_of = [0.25f64, 0.25, 0.2];
    for (tag, bytes) in [("lossless", write(&file)), ("compact", write_compact(&file).unwrap())] {
        let (header, entries) = read_header_and_table(&bytes).unwrap();
        assert_eq!(header.minor, 2, "{tag}");
        let last = entries.last().unwrap();
        let (width, encoding) = if tag == "lossless" { (4, 0) } else { (2, 1) };
        assert_eq!((last.kind, last.length), (SectionKind::SampleAreas.code(), 16 + 3 * width), "{tag}");
        assert_eq!(bytes[last.offset as usize + 4], encoding, "{tag}");
        let back = read(&bytes).unwrap();
        let s = back.samples.as_ref().unwrap();
        let got = s.areas.clone().unwrap();
        for ((g, w), r) in got.iter().zip(&areas).zip(radius_of) {
            let (g, w) = (f64::from(*g), f64::from(*w));
            let bound = if tag == "lossless" { 0.0 } else { (w * 2f64.powi(-11)).max(r * r * 2f64.powi(-25)) };
            assert!((g - w).abs() <= bound, "{tag}: {g} vs {w}");
        }
        // Per sphere (2, 0 and 1 samples), parallel to the points.
        assert_eq!(s.areas_of(0).map(<[f32]>::len), Some(2), "{tag}");
        assert_eq!(s.areas_of(1).map(<[f32]>::len), Some(0), "{tag}");
        assert_eq!(s.areas_of(2), Some(&got[2..]), "{tag}");
    }
    // Ratios that round to f16 2.0 (0.125 / 0.25², and 0.08 / 0.2² = 1.99999997 in f32 terms)
    // decode by the spec's formula (h · r) · r in double, rounded once to f32.
    file.samples.as_mut().unwrap().areas = Some(vec![0.125, 0.0, 0.08]);
    let back = read(&write_compact(&file).unwrap()).unwrap();
    let r2 = f64::from(0.2f32);
    assert_eq!(back.samples.unwrap().areas.unwrap(), vec![0.125, 0.0, (2.0 * r2 * r2) as f32]);
    // A ratio past the f16 range falls back to f32 (encoding 0) for the whole section.
    file.samples.as_mut().unwrap().areas = Some(vec![1.0e4, 0.0, 0.08]);
    let bytes = write_compact(&file).unwrap();
    let (_, entries) = read_header_and_table(&bytes).unwrap();
    let last = entries.last().unwrap();
    assert_eq!((last.length, bytes[last.offset as usize + 4]), (28, 0));
    assert_eq!(read(&bytes).unwrap().samples.unwrap().areas.unwrap(), vec![1.0e4, 0.0, 0.08]);
    // Without areas the writers keep their minors.
    let plain = full_file();
    assert_eq!(read_header_and_table(&write(&plain)).unwrap().0.minor, 0);
    assert_eq!(read_header_and_table(&write_compact(&plain).unwrap()).unwrap().0.minor, 1);
}
