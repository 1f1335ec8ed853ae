//! The loader never panics, never reads out of bounds and rejects every kind of damage with a
//! distinct error, on a real baked blob (the FaceCap head).

use facebake::ground_truth::SplitMix64;
use facebake_runtime::deformer::linear::{DerivedMarker, LinearDeformer};
use facebake_runtime::deformer::planar::PlanarDeformer;
use facebake_runtime::deformer::rbf::RbfDeformer;
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::header::header_for;
use facebake_runtime::format::records::{
    Bytes, HEADER_LEN, MAX_MARKER_PAIRS, MAX_TRIANGLES, PLANAR_INFLUENCE_BYTES, SECTION_ALIGN,
};
use facebake_runtime::format::RigData;
use facebake_runtime::Rig;
use facebake_runtime::{LoadError, Section};
use facebake_tests::{facecap_blobs, facecap_default, facecap_planar, facecap_weights, reseal};

/// Every FaceCap rig, the planar-bones one included: (name, blob).
fn all_blobs() -> Vec<(&'static str, &'static [u8])> {
    let mut v = facecap_blobs().to_vec();
    v.push(("planar", &facecap_planar().blob));
    v
}

fn blob() -> Vec<u8> {
    facecap_default().1.blob.clone()
}

/// Re-encode an edited payload into a sealed blob.
fn seal(data: &RigData<'_>) -> Vec<u8> {
    let payload = postcard::to_allocvec(data).unwrap();
    let mut out = header_for(&payload).unwrap().to_vec();
    out.extend_from_slice(&payload);
    out
}

#[test]
fn the_real_blobs_load() {
    for (name, b) in all_blobs() {
        let rig = Rig::from_bytes(b).unwrap();
        assert_eq!(rig.vertex_count(), 2694, "{name}");
        assert_eq!(rig.marker_count(), 40, "{name}");
        assert_eq!(rig.marker_names().count(), 40, "{name}");
    }
    assert!(matches!(
        Rig::from_bytes(&blob()).unwrap().deformer(),
        Deformer::Rbf(_)
    ));
}

#[test]
fn every_truncation_is_rejected() {
    truncations(&blob());
    truncations(&facecap_planar().blob);
}

fn truncations(b: &[u8]) {
    for len in 0..b.len() {
        match Rig::from_bytes(&b[..len]) {
            Err(LoadError::Truncated { found, .. }) => assert_eq!(found, len),
            Err(LoadError::BadMagic) if len >= 8 => {
                panic!("truncation at {len} reported as bad magic")
            }
            Err(_) if len < HEADER_LEN => {}
            other => panic!("truncation at {len} gave {other:?}"),
        }
    }
}

#[test]
fn random_flips_are_caught_by_the_checksum_or_the_header() {
    flips(&blob());
    flips(&facecap_planar().blob);
}

fn flips(b: &[u8]) {
    let mut rng = SplitMix64(1);
    for _ in 0..2000 {
        let mut c = b.to_vec();
        let at = (rng.next_u64() % c.len() as u64) as usize;
        c[at] ^= 1 << (rng.next_u64() % 8);
        let err = Rig::from_bytes(&c).expect_err("a flipped bit must not load");
        if at >= HEADER_LEN {
            assert!(
                matches!(err, LoadError::ChecksumMismatch { .. }),
                "payload flip at {at}: {err:?}"
            );
        }
    }
}

#[test]
fn resealed_random_damage_never_panics() {
    for (name, b) in all_blobs() {
        resealed_damage(name, b);
    }
}

fn resealed_damage(name: &str, b: &[u8]) {
    // The CRC is fixed up after the damage, so decoding and validation see it.
    let mut rng = SplitMix64(2);
    let mut loaded = 0;
    for round in 0..3000 {
        let mut c = b.to_vec();
        let flips = 1 + (round % 4);
        for _ in 0..flips {
            let at = HEADER_LEN + (rng.next_u64() % (c.len() - HEADER_LEN) as u64) as usize;
            c[at] = rng.next_u64() as u8;
        }
        reseal(&mut c);
        if let Ok(rig) = Rig::from_bytes(&c) {
            // Whatever loads must deform without panicking.
            loaded += 1;
            let markers = vec![[1 << 20, -(1 << 21), 3]; rig.marker_count()];
            let mut out = vec![[0; 3]; rig.vertex_count()];
            rig.deform(&markers, &mut out).unwrap();
        }
    }
    // Most damage to rest positions is undetectable by design (any i16 is valid); the count is
    // here so a loader that rejects everything is noticed.
    assert!(
        loaded > 100,
        "{name}: only {loaded} of 3000 damaged-but-valid blobs loaded"
    );
}

#[test]
fn every_header_error_is_distinct() {
    let b = blob();
    let mut c = b.clone();
    c[0] = b'X';
    assert_eq!(Rig::from_bytes(&c).unwrap_err(), LoadError::BadMagic);
    use facebake_runtime::format::records::{OLDEST_VERSION, VERSION};
    let (oldest, version) = (OLDEST_VERSION as u8, VERSION as u8);
    for old_or_new in [1u8, oldest - 1, version + 1] {
        let mut c = b.clone();
        c[8] = old_or_new;
        assert_eq!(
            Rig::from_bytes(&c).unwrap_err(),
            LoadError::UnsupportedVersion {
                found: u16::from(old_or_new)
            }
        );
    }
    // Every version from the oldest read loads (the version is outside the checksum).
    for readable in oldest..version {
        let mut c = b.clone();
        c[8] = readable;
        assert!(Rig::from_bytes(&c).is_ok(), "version {readable}");
    }
    let mut c = b.clone();
    c[10] = 1;
    assert_eq!(Rig::from_bytes(&c).unwrap_err(), LoadError::BadReserved);
    let mut c = b.clone();
    c.push(0);
    assert_eq!(
        Rig::from_bytes(&c).unwrap_err(),
        LoadError::TrailingBytes { extra: 1 }
    );
    let mut c = b.clone();
    c[19] ^= 0x80;
    assert!(matches!(
        Rig::from_bytes(&c).unwrap_err(),
        LoadError::ChecksumMismatch { .. }
    ));
    let mut c = b.clone();
    c.truncate(HEADER_LEN + 10);
    c[12..16].copy_from_slice(&10u32.to_le_bytes());
    reseal(&mut c);
    assert_eq!(Rig::from_bytes(&c).unwrap_err(), LoadError::Malformed);
}

#[test]
fn every_payload_error_is_distinct() {
    let b = facecap_weights().blob.clone();
    let good = *Rig::from_bytes(&b).unwrap().data();
    let Deformer::Linear(lin) = good.deformer else {
        panic!("the linear deformer bakes a linear rig")
    };

    let mut extra = b.clone();
    extra.push(0);
    let len = (extra.len() - HEADER_LEN) as u32;
    extra[12..16].copy_from_slice(&len.to_le_bytes());
    reseal(&mut extra);
    assert_eq!(
        Rig::from_bytes(&extra).unwrap_err(),
        LoadError::PayloadTrailingBytes
    );

    let mut d = good;
    d.space.half_extent = 0.0;
    assert_eq!(Rig::from_bytes(&seal(&d)).unwrap_err(), LoadError::BadSpace);

    let mut d = good;
    d.marker_count = 0;
    assert_eq!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::BadMarkerCount { found: 0 }
    );

    let mut d = good;
    d.marker_count = 39;
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::MarkerNames,
            ..
        }
    ));

    let mut names = good.marker_names.0.to_vec();
    names[1] = 0xFF; // not UTF-8
    let mut d = good;
    d.marker_names = Bytes(&names);
    assert_eq!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::BadMarkerName { marker: 0 }
    );

    let mut d = good;
    d.vertex_count -= 1;
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::VertexRest,
            ..
        }
    ));

    let mut d = good;
    d.vertex_rest_align = Bytes(&[0, 0, 7]);
    assert_eq!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::BadAlignment {
            section: Section::VertexRest
        }
    );

    let mut d = good;
    d.marker_rest = Bytes(&good.marker_rest.0[..good.marker_rest.0.len() - 12]);
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::MarkerRest,
            ..
        }
    ));

    let short = &lin.pair_counts.0[1..];
    let fewer = &lin.pairs.0[6..];
    // Vertex 0 has four pairs: 16 bytes of weights, then four marker pair indices.
    let mut bad_index = lin.pairs.0.to_vec();
    bad_index[16..18].copy_from_slice(&600u16.to_le_bytes());
    let mut bad_marker = lin.marker_pairs.0.to_vec();
    bad_marker[1] = 200; // marker 200 of 40
    let odd_table = &lin.marker_pairs.0[1..];
    let too_many = vec![0u8; 2 * (MAX_MARKER_PAIRS + 1)];
    let mut bad_sum = lin.pairs.0.to_vec();
    bad_sum[0] ^= 1; // the first weight off by one unit
                     // Vertex 0's first two weights ±20,000 apart from before: still summing to 2^F, but with
                     // magnitudes summing past i16::MAX.
    let mut heavy = lin.pairs.0.to_vec();
    for (at, delta) in [(0, 20_000), (2, -20_000)] {
        let w = i16::from_le_bytes([heavy[at], heavy[at + 1]]) + delta;
        heavy[at..at + 2].copy_from_slice(&w.to_le_bytes());
    }
    // Derived markers: marker 40 is the first past the rig's 40.
    let up = [0, 1 << 14, 0];
    let many_derived = derived(0, up).repeat(256 - 40 + 1);
    let two = [derived(3, up), derived(0, [0; 3])].concat();
    let long = derived(3, [1 << 14, 1, 0]);
    let mut reserved = derived(3, up);
    reserved[1] = 1;
    let mut past_derived = lin.marker_pairs.0.to_vec();
    past_derived[1] = 41; // one derived marker (40): 41 is past it
    let past = derived(40, up);
    // Derived means: one naming marker 40 (past the rig's 40), one of eight markers, one with
    // a stray byte past its two sources.
    let mean_past = [3, 2, 40, 0, 0, 0, 0, 0];
    let mean_of_eight = [0, 8, 1, 2, 3, 4, 5, 6];
    let mean_stray = [0, 2, 1, 0, 0, 0, 0, 9];
    let cases: [(LinearDeformer<'_>, Option<LoadError>); 20] = [
        (
            LinearDeformer {
                derived_markers: Bytes(&two),
                ..lin
            },
            Some(LoadError::BadDerivedMarker { derived: 1 }),
        ),
        (
            LinearDeformer {
                derived_markers: Bytes(&many_derived),
                ..lin
            },
            Some(LoadError::BadDerivedMarker { derived: 256 - 40 }),
        ),
        (
            LinearDeformer {
                derived_markers: Bytes(&derived(0, up)),
                marker_pairs: Bytes(&past_derived),
                ..lin
            },
            Some(LoadError::PairMarkerOutOfRange {
                pair: 0,
                marker: 41,
            }),
        ),
        (
            LinearDeformer {
                derived_markers: Bytes(&[0]),
                ..lin
            },
            None,
        ),
        (
            LinearDeformer {
                pairs_align: Bytes(&[0; 4]),
                ..lin
            },
            Some(LoadError::BadAlignment {
                section: Section::Pairs,
            }),
        ),
        (
            LinearDeformer {
                pairs_align: Bytes(&[1]),
                ..lin
            },
            Some(LoadError::BadAlignment {
                section: Section::Pairs,
            }),
        ),
        (
            LinearDeformer {
                max_influences: 0,
                ..lin
            },
            Some(LoadError::BadMaxInfluences { found: 0 }),
        ),
        (
            LinearDeformer {
                max_influences: 65,
                ..lin
            },
            Some(LoadError::BadMaxInfluences { found: 65 }),
        ),
        (
            LinearDeformer {
                weight_frac_bits: 23,
                ..lin
            },
            Some(LoadError::BadWeightFormat { found: 23 }),
        ),
        (
            // K = 3 allows three pairs; the vertices have four.
            LinearDeformer {
                max_influences: 3,
                ..lin
            },
            Some(LoadError::TooManyInfluencePairs {
                vertex: 0,
                count: 4,
            }),
        ),
        (
            LinearDeformer {
                pairs: Bytes(&bad_index),
                ..lin
            },
            Some(LoadError::PairIndexOutOfRange {
                vertex: 0,
                pair: 600,
            }),
        ),
        (
            LinearDeformer {
                marker_pairs: Bytes(&bad_marker),
                ..lin
            },
            Some(LoadError::PairMarkerOutOfRange {
                pair: 0,
                marker: 200,
            }),
        ),
        (
            LinearDeformer {
                marker_pairs: Bytes(&too_many),
                ..lin
            },
            Some(LoadError::TooManyMarkerPairs {
                found: MAX_MARKER_PAIRS + 1,
            }),
        ),
        (
            LinearDeformer {
                pairs: Bytes(&bad_sum),
                ..lin
            },
            Some(LoadError::WeightsNotNormalised { vertex: 0 }),
        ),
        (
            LinearDeformer {
                pairs: Bytes(&heavy),
                ..lin
            },
            Some(LoadError::WeightsTooLarge { vertex: 0 }),
        ),
        (
            // The linear form's weights fit 16 bits: at most 14 fractional bits.
            LinearDeformer {
                weight_frac_bits: 15,
                ..lin
            },
            Some(LoadError::BadWeightFormat { found: 15 }),
        ),
        (
            LinearDeformer {
                marker_pairs: Bytes(odd_table),
                ..lin
            },
            None,
        ),
        (
            LinearDeformer {
                pair_counts: Bytes(short),
                ..lin
            },
            None,
        ),
        (
            LinearDeformer {
                pairs: Bytes(fewer),
                ..lin
            },
            None,
        ),
        (
            LinearDeformer {
                pair_counts: Bytes(&lin.pair_counts.0[..0]),
                ..lin
            },
            None,
        ),
    ];
    // A rig's only derived marker, refused whatever is wrong with its record.
    let refused: [(&str, &[u8]); 6] = [
        ("a source past the markers", &past),
        ("a projection's direction not of unit length", &long),
        ("a projection's reserved byte set", &reserved),
        ("a mean's source past the markers", &mean_past),
        ("a mean of eight", &mean_of_eight),
        ("a stray byte after a mean's sources", &mean_stray),
    ];
    for (what, record) in refused {
        let d = RigData {
            deformer: Deformer::Linear(LinearDeformer {
                derived_markers: Bytes(record),
                ..lin
            }),
            ..good
        };
        let got = Rig::from_bytes(&seal(&d)).unwrap_err();
        assert_eq!(got, LoadError::BadDerivedMarker { derived: 0 }, "{what}");
    }
    for (i, (edited, want)) in cases.into_iter().enumerate() {
        let d = RigData {
            deformer: Deformer::Linear(edited),
            ..good
        };
        let got = Rig::from_bytes(&seal(&d)).unwrap_err();
        match want {
            Some(want) => assert_eq!(got, want, "case {i}"),
            None => assert!(
                matches!(got, LoadError::SectionLength { .. }),
                "case {i}: {got:?}"
            ),
        }
    }
    // A marker pair may name a derived marker.
    let mut on_derived = lin.marker_pairs.0.to_vec();
    on_derived[1] = 40;
    let on_y = derived(0, [0, 1 << 14, 0]);
    let d = RigData {
        deformer: Deformer::Linear(LinearDeformer {
            derived_markers: Bytes(&on_y),
            marker_pairs: Bytes(&on_derived),
            ..lin
        }),
        ..good
    };
    let base = Rig::from_bytes(&seal(&good)).unwrap().cost().multiply_adds;
    let projected = Rig::from_bytes(&seal(&d)).unwrap().cost().multiply_adds;
    assert_eq!(
        projected,
        base + 6,
        "a projection's six multiplies are in the cost"
    );
    // And on a derived mean of seven markers.
    let mean = [0, 7, 1, 2, 3, 4, 5, 39];
    let d = RigData {
        deformer: Deformer::Linear(LinearDeformer {
            derived_markers: Bytes(&mean),
            marker_pairs: Bytes(&on_derived),
            ..lin
        }),
        ..good
    };
    let averaged = Rig::from_bytes(&seal(&d)).unwrap().cost().multiply_adds;
    assert_eq!(
        averaged,
        base + 3,
        "a mean's three multiplies are in the cost"
    );
}

/// A derived marker's record: its source, a zero byte and its Q1.14 direction.
fn derived(source: u8, direction: [i16; 3]) -> Vec<u8> {
    DerivedMarker::Projection { source, direction }
        .record()
        .to_vec()
}

#[test]
fn every_coefficient_error_is_distinct() {
    let b = blob();
    let good = *Rig::from_bytes(&b).unwrap().data();
    let Deformer::Rbf(rbf) = good.deformer else {
        panic!("the default is the RBF deformer")
    };
    let markers = usize::from(good.marker_count);
    let mut bad_shift = rbf.row_shifts.0.to_vec();
    bad_shift[3] = 0;
    let mut bad_row = rbf.matrix.0.to_vec();
    bad_row[2 * markers * 5] ^= 1; // row 5 no longer sums to 0
    let mut bad_unit = rbf.matrix.0.to_vec();
    bad_unit[2 * markers * markers] ^= 1; // the β₀ row no longer sums to 2^s
    let mut bad_index = rbf.influences.0.to_vec();
    bad_index[4 * 8 * 3 + 4] = 41; // vertex 3, second term: centre 41 of 40
    let short = &rbf.matrix.0[2..];
    let cases: [(RbfDeformer<'_>, LoadError); 7] = [
        (
            RbfDeformer {
                influences_per_vertex: 0,
                ..rbf
            },
            LoadError::BadMaxInfluences { found: 0 },
        ),
        (
            RbfDeformer {
                weight_frac_bits: 7,
                ..rbf
            },
            LoadError::BadWeightFormat { found: 7 },
        ),
        (
            RbfDeformer {
                row_shifts: Bytes(&bad_shift),
                ..rbf
            },
            LoadError::BadRowShift { row: 3, shift: 0 },
        ),
        (
            RbfDeformer {
                matrix: Bytes(&bad_row),
                ..rbf
            },
            LoadError::CoefficientsNotNormalised { row: 5 },
        ),
        (
            RbfDeformer {
                matrix: Bytes(&bad_unit),
                ..rbf
            },
            LoadError::CoefficientsNotNormalised { row: markers },
        ),
        (
            RbfDeformer {
                influences: Bytes(&bad_index),
                ..rbf
            },
            LoadError::MarkerIndexOutOfRange {
                vertex: 3,
                marker: 41,
            },
        ),
        (
            RbfDeformer {
                matrix: Bytes(short),
                ..rbf
            },
            LoadError::SectionLength {
                section: Section::Matrix,
                expected: rbf.matrix.0.len(),
                found: short.len(),
            },
        ),
    ];
    for (i, (edited, want)) in cases.into_iter().enumerate() {
        let d = RigData {
            deformer: Deformer::Rbf(edited),
            ..good
        };
        assert_eq!(Rig::from_bytes(&seal(&d)).unwrap_err(), want, "case {i}");
    }
    // Fewer influences than vertices × K, and the affine flag without its rows.
    let fewer = &rbf.influences.0[32..];
    let d = RigData {
        deformer: Deformer::Rbf(RbfDeformer {
            influences: Bytes(fewer),
            ..rbf
        }),
        ..good
    };
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::Influences,
            ..
        }
    ));
    let d = RigData {
        deformer: Deformer::Rbf(RbfDeformer {
            affine: false,
            ..rbf
        }),
        ..good
    };
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::RowShifts,
            ..
        }
    ));
}

#[test]
fn every_planar_error_is_distinct() {
    let b = &facecap_planar().blob;
    let good = *Rig::from_bytes(b).unwrap().data();
    let Deformer::Planar(p) = good.deformer else {
        panic!("the planar bake has a planar deformer")
    };
    // Triangle 0 with a marker past the last one; with all three corners on one marker.
    let mut tris = p.triangles.0.to_vec();
    tris[1] = 200;
    let mut flat = p.triangles.0.to_vec();
    flat[1] = flat[0];
    flat[2] = flat[0];
    // Vertex 0's first record: triangle out of range; weight changed.
    let mut records = p.influences.0.to_vec();
    let head = |r: &[u8]| u16::from_le_bytes([r[0], r[1]]);
    let region_bits = head(&records) & 0xE000;
    records[..2].copy_from_slice(&(region_bits | p.triangle_count).to_le_bytes());
    let mut weight = p.influences.0.to_vec();
    weight[2] ^= 1;
    let mut counts = p.influence_counts.0.to_vec();
    counts[0] = 0;
    let (crowded, &crowd) = p
        .influence_counts
        .0
        .iter()
        .enumerate()
        .find(|(_, &c)| c > 1)
        .unwrap();
    let short_tris = &p.triangles.0[..p.triangles.0.len() - 3];
    let fewer = &p.influences.0[..p.influences.0.len() - PLANAR_INFLUENCE_BYTES];
    let cases: Vec<(PlanarDeformer<'_>, LoadError)> = vec![
        (
            PlanarDeformer {
                max_influences: 0,
                ..p
            },
            LoadError::BadMaxInfluences { found: 0 },
        ),
        (
            PlanarDeformer {
                triangle_count: 0,
                ..p
            },
            LoadError::BadTriangleCount { found: 0 },
        ),
        (
            PlanarDeformer {
                triangle_count: MAX_TRIANGLES as u16 + 1,
                ..p
            },
            LoadError::BadTriangleCount {
                found: MAX_TRIANGLES as u16 + 1,
            },
        ),
        (
            PlanarDeformer {
                triangles: Bytes(short_tris),
                ..p
            },
            LoadError::SectionLength {
                section: Section::Triangles,
                expected: p.triangles.0.len(),
                found: short_tris.len(),
            },
        ),
        (
            PlanarDeformer {
                triangles: Bytes(&tris),
                ..p
            },
            LoadError::TriangleMarkerOutOfRange {
                triangle: 0,
                marker: 200,
            },
        ),
        (
            PlanarDeformer {
                triangles: Bytes(&flat),
                ..p
            },
            LoadError::DegenerateRestTriangle { triangle: 0 },
        ),
        (
            PlanarDeformer {
                influences: Bytes(&records),
                ..p
            },
            LoadError::TriangleIndexOutOfRange {
                vertex: 0,
                triangle: p.triangle_count,
            },
        ),
        (
            PlanarDeformer {
                influences: Bytes(&weight),
                ..p
            },
            LoadError::WeightsNotNormalised { vertex: 0 },
        ),
        (
            PlanarDeformer {
                max_influences: 1,
                ..p
            },
            LoadError::TooManyInfluences {
                vertex: crowded,
                count: crowd,
            },
        ),
    ];
    for (i, (edited, want)) in cases.into_iter().enumerate() {
        let d = RigData {
            deformer: Deformer::Planar(edited),
            ..good
        };
        assert_eq!(Rig::from_bytes(&seal(&d)).unwrap_err(), want, "case {i}");
    }
    // A vertex without influences, and a short influence section: length errors.
    for edited in [
        PlanarDeformer {
            influence_counts: Bytes(&counts),
            ..p
        },
        PlanarDeformer {
            influences: Bytes(fewer),
            ..p
        },
    ] {
        let d = RigData {
            deformer: Deformer::Planar(edited),
            ..good
        };
        assert!(matches!(
            Rig::from_bytes(&seal(&d)).unwrap_err(),
            LoadError::SectionLength {
                section: Section::Influences,
                ..
            }
        ));
    }
}

#[test]
fn every_normals_error_is_distinct() {
    use facebake_runtime::normals::Normals;
    let b = blob();
    let good = *Rig::from_bytes(&b).unwrap().data();
    let n = good.normals;
    assert_eq!(n.index_bytes, 2, "FaceCap's 2694 vertices take u16 indices");
    let vertices = good.vertex_count as usize;
    // Vertex 3's rest normal with x = 1.0 + 1 LSB.
    let mut bad_rest = n.rest.0.to_vec();
    bad_rest[3 * 6..3 * 6 + 2].copy_from_slice(&16385i16.to_le_bytes());
    // The first corner of the first vertex with a fan names vertex `vertices`.
    let first = n.fan_counts.0.iter().position(|&c| c > 0).unwrap();
    let mut bad_corner = n.corners.0.to_vec();
    bad_corner[..2].copy_from_slice(&(vertices as u16).to_le_bytes());
    // The first weld pair, in turn: its vertex swapped for one with a fan, its canonical vertex
    // for one without (itself), and the second pair moved before the first.
    assert!(n.welds.0.len() >= 8, "FaceCap has seams");
    let mut welded_has_fan = n.welds.0.to_vec();
    welded_has_fan[..2].copy_from_slice(&(first as u16).to_le_bytes());
    let mut canonical_welded = n.welds.0.to_vec();
    canonical_welded.copy_within(0..2, 2);
    let mut unordered = n.welds.0.to_vec();
    unordered.copy_within(4..6, 0);
    let odd = &n.welds.0[..3];
    let cases: [(Normals<'_>, LoadError); 9] = [
        (
            Normals {
                index_bytes: 3,
                ..n
            },
            LoadError::BadIndexWidth { found: 3 },
        ),
        (
            Normals {
                rest: Bytes(&bad_rest),
                ..n
            },
            LoadError::BadRestNormal { vertex: 3 },
        ),
        (
            Normals {
                rest: Bytes(&n.rest.0[6..]),
                ..n
            },
            LoadError::SectionLength {
                section: Section::RestNormals,
                expected: n.rest.0.len(),
                found: n.rest.0.len() - 6,
            },
        ),
        (
            Normals {
                fan_counts: Bytes(&n.fan_counts.0[1..]),
                ..n
            },
            LoadError::SectionLength {
                section: Section::FanCounts,
                expected: vertices,
                found: vertices - 1,
            },
        ),
        (
            Normals {
                corners: Bytes(&n.corners.0[4..]),
                ..n
            },
            LoadError::SectionLength {
                section: Section::Corners,
                expected: n.corners.0.len(),
                found: n.corners.0.len() - 4,
            },
        ),
        (
            Normals {
                corners: Bytes(&bad_corner),
                ..n
            },
            LoadError::CornerOutOfRange {
                vertex: first,
                corner: vertices as u32,
            },
        ),
        (
            Normals {
                welds: Bytes(&welded_has_fan),
                ..n
            },
            LoadError::BadWeld { entry: 0 },
        ),
        (
            Normals {
                welds: Bytes(&canonical_welded),
                ..n
            },
            LoadError::BadWeld { entry: 0 },
        ),
        (
            Normals {
                welds: Bytes(&unordered),
                ..n
            },
            LoadError::BadWeld { entry: 1 },
        ),
    ];
    for (i, (edited, want)) in cases.into_iter().enumerate() {
        let d = RigData {
            normals: edited,
            ..good
        };
        assert_eq!(Rig::from_bytes(&seal(&d)).unwrap_err(), want, "case {i}");
    }
    let d = RigData {
        normals: Normals {
            welds: Bytes(odd),
            ..n
        },
        ..good
    };
    assert!(matches!(
        Rig::from_bytes(&seal(&d)).unwrap_err(),
        LoadError::SectionLength {
            section: Section::Welds,
            ..
        }
    ));
}

/// `fixtures/repro/blob_marker_name_terminal_escape.fbk` is the golden linear rig with its first
/// marker named by a terminal escape sequence (what `baker/tests/hostile.rs` feeds `inspect`),
/// re-encoded for this format version: rewritten with `FACEBAKE_BLESS=1`.
#[test]
fn terminal_escape_repro_is_the_golden_rig_renamed() {
    let b = facecap_weights().blob.clone();
    let good = *Rig::from_bytes(&b).unwrap().data();
    let mut names = vec![13u8];
    names.extend_from_slice(b"\x1b[2J\x1b[31mPWN\n");
    // Every name after the first, as it was.
    let first = usize::from(good.marker_names.0[0]);
    names.extend_from_slice(&good.marker_names.0[1 + first..]);
    let mut d = good;
    d.marker_names = Bytes(&names);
    let want = seal(&d);
    let path = facebake_tests::fixture("repro").join("blob_marker_name_terminal_escape.fbk");
    if std::env::var_os("FACEBAKE_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&path, &want).unwrap();
    }
    assert_eq!(
        std::fs::read(&path).unwrap(),
        want,
        "{} is stale (rerun with FACEBAKE_BLESS=1)",
        path.display()
    );
    assert!(Rig::from_bytes(&want).is_ok());
}

/// Every baked rig starts `vertex_rest` and a linear rig's `pairs` at a multiple of
/// `SECTION_ALIGN` from the blob's first byte (what the Cortex-M4 kernel's aligned loads need).
#[test]
fn baked_blobs_align_their_hot_sections() {
    for (name, blob) in all_blobs() {
        let rig = Rig::from_bytes(blob).unwrap();
        let at = |s: &[u8]| s.as_ptr() as usize - blob.as_ptr() as usize;
        assert_eq!(
            at(rig.data().vertex_rest.0) % SECTION_ALIGN,
            0,
            "{name}: vertex_rest"
        );
        if let Deformer::Linear(l) = rig.deformer() {
            assert_eq!(at(l.pairs.0) % SECTION_ALIGN, 0, "{name}: pairs");
        }
    }
}
