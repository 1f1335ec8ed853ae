//! The capture stages' part of the loader: every invalid field is rejected with its own error,
//! and random damage to the stages section never makes loading or playing panic.

use facebake::ground_truth::SplitMix64;
use facebake::stages::{RetargetKind, StagesConfig};
use facebake_runtime::format::header::header_for;
use facebake_runtime::format::records::{Bytes, HEADER_LEN};
use facebake_runtime::format::{self, RigData};
use facebake_runtime::stages::retarget::{ProportionalRetarget, RbfRetarget, Retarget};
use facebake_runtime::stages::Stages;
use facebake_runtime::{LoadError, StagesLoadError, StagesSection};
use facebake_runtime::{PlayState, Rig};
use facebake_tests::{jawmocap_rig, reseal, JawMoCapRig};

/// JawMoCap's rig with the RBF retargeting map, whose sections have the most fields to damage
/// (the default's proportional retargeting is checked in
/// [`proportional_retargeting_errors_are_distinct`]), and the markers' smoothing on (the
/// default bake leaves this clean take unsmoothed).
fn rig() -> &'static JawMoCapRig {
    static CELL: std::sync::OnceLock<JawMoCapRig> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        jawmocap_rig(&StagesConfig {
            retarget: RetargetKind::Rbf,
            smoothing: facebake::stages::SmoothingUse::On(
                facebake::stages::temporal::SmoothingConfig::default(),
            ),
            ..StagesConfig::default()
        })
    })
}

fn seal(data: &RigData<'_>) -> Vec<u8> {
    let payload = postcard::to_allocvec(data).unwrap();
    let mut out = header_for(&payload).unwrap().to_vec();
    out.extend_from_slice(&payload);
    out
}

fn rbf<'a, 'b>(d: &'b mut RigData<'a>) -> &'b mut RbfRetarget<'a> {
    match &mut d.stages.as_mut().unwrap().retarget {
        Retarget::Rbf(r) => r,
        Retarget::Proportional(_) => panic!("this rig retargets by RBF"),
    }
}

fn rbf_of<'a>(s: &Stages<'a>) -> RbfRetarget<'a> {
    match s.retarget {
        Retarget::Rbf(r) => r,
        Retarget::Proportional(_) => panic!("this rig retargets by RBF"),
    }
}

#[test]
fn proportional_retargeting_errors_are_distinct() {
    let j = jawmocap_rig(&StagesConfig::default());
    let good = *Rig::from_bytes(&j.baked.blob).unwrap().data();
    let Retarget::Proportional(p) = good.stages.expect("stages").retarget else {
        panic!("the default bake retargets proportionally");
    };
    let with = |q: ProportionalRetarget<'static>| {
        let mut d = good;
        d.stages.as_mut().unwrap().retarget = Retarget::Proportional(q);
        stages_error(&d)
    };
    let matrices: &'static [u8] = p.matrices.0.to_vec().leak();
    let rest: &'static [u8] = p.rest.0.to_vec().leak();
    let ok = ProportionalRetarget {
        shift: p.shift,
        matrices: Bytes(matrices),
        rest: Bytes(rest),
    };
    for shift in [0, 41] {
        assert_eq!(
            with(ProportionalRetarget { shift, ..ok }),
            StagesLoadError::BadShift
        );
    }
    assert!(matches!(
        with(ProportionalRetarget {
            matrices: Bytes(&matrices[..36]),
            ..ok
        }),
        StagesLoadError::SectionLength {
            section: StagesSection::Matrices,
            ..
        }
    ));
    assert!(matches!(
        with(ProportionalRetarget {
            rest: Bytes(&rest[12..]),
            ..ok
        }),
        StagesLoadError::SectionLength {
            section: StagesSection::Rest,
            ..
        }
    ));
}

fn stages_error(data: &RigData<'_>) -> StagesLoadError {
    match Rig::from_bytes(&seal(data)) {
        Err(LoadError::Stages(e)) => e,
        other => panic!("expected a stages error, got {other:?}"),
    }
}

#[test]
fn every_stages_error_is_distinct() {
    let blob = &rig().baked.blob;
    let good = *Rig::from_bytes(blob).unwrap().data();
    let s = good.stages.expect("stages");
    let with = |f: &dyn Fn(&mut format::RigData<'_>)| {
        let mut d = good;
        f(&mut d);
        stages_error(&d)
    };
    assert_eq!(
        with(&|d| d.stages.as_mut().unwrap().actor_space.half_extent = f32::NAN),
        StagesLoadError::BadActorSpace
    );
    let short = &s.actor_neutral.0[..12];
    assert!(matches!(
        with(&|d| d.stages.as_mut().unwrap().actor_neutral = Bytes(short)),
        StagesLoadError::SectionLength {
            section: StagesSection::ActorNeutral,
            ..
        }
    ));
    let mut far = s.actor_neutral.0.to_vec();
    far[12..16].copy_from_slice(&(5i32 << 24).to_le_bytes());
    let far: &'static [u8] = far.leak();
    assert_eq!(
        with(&|d| d.stages.as_mut().unwrap().actor_neutral = Bytes(far)),
        StagesLoadError::NeutralOutOfRange { marker: 1 }
    );
    for head in [&[0u8, 1][..], &[2, 1, 3], &[0, 1, 200], &[0; 33]] {
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().head_markers = Bytes(head)),
            StagesLoadError::BadHeadMarkers,
            "{head:?}"
        );
    }
    let head0 = s.head_markers.0[0];
    for anchors in [vec![3u8, 2], vec![200], vec![head0]] {
        let anchors: &'static [u8] = anchors.leak();
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().anchors = Bytes(anchors)),
            StagesLoadError::BadAnchors,
            "{anchors:?}"
        );
    }
    // An anchor must have no fill neighbours (marker 1 has some in the real blob).
    let with_fill: &'static [u8] = vec![1u8].leak();
    let one_head = s.head_markers.0.contains(&1);
    if !one_head {
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().anchors = Bytes(with_fill)),
            StagesLoadError::BadAnchors
        );
    }
    for bad in [0, -1, (1 << 30) + 1] {
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().max_displacement = bad),
            StagesLoadError::BadMaxDisplacement
        );
    }
    for bad in [0, -1, (1 << 30) + 1] {
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().head_tolerance = bad),
            StagesLoadError::BadHeadTolerance
        );
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().max_step = bad),
            StagesLoadError::BadMaxStep
        );
    }
    // The head refit's cutoff: 0 (none) or within [2^-12, 1] actor unit.
    assert!(s.refit_cutoff > 0, "the default bake refits");
    for bad in [-1, 1, (1 << 12) - 1, (1 << 24) + 1, i32::MIN] {
        assert_eq!(
            with(&|d| d.stages.as_mut().unwrap().refit_cutoff = bad),
            StagesLoadError::BadRefitCutoff,
            "{bad}"
        );
    }
    let smoothing = s.smoothing.expect("the rig smooths");
    use facebake_runtime::stages::smoothing::{MAX_CUTOFF, MAX_SPEED_GAIN};
    for bad in [0, MAX_CUTOFF + 1] {
        assert_eq!(
            with(&|d| {
                d.stages.as_mut().unwrap().smoothing =
                    Some(facebake_runtime::stages::smoothing::Smoothing {
                        min_cutoff: bad,
                        ..smoothing
                    })
            }),
            StagesLoadError::BadMinCutoff
        );
        assert_eq!(
            with(&|d| {
                d.stages.as_mut().unwrap().smoothing =
                    Some(facebake_runtime::stages::smoothing::Smoothing {
                        derivative_cutoff: bad,
                        ..smoothing
                    })
            }),
            StagesLoadError::BadDerivativeCutoff
        );
    }
    assert_eq!(
        with(&|d| {
            d.stages.as_mut().unwrap().smoothing =
                Some(facebake_runtime::stages::smoothing::Smoothing {
                    speed_gain: MAX_SPEED_GAIN + 1,
                    ..smoothing
                })
        }),
        StagesLoadError::BadSpeedGain
    );
    let mut fill = s.fill.0.to_vec();
    fill[16..20].copy_from_slice(&((1u32 << 16) << 8 | 1).to_le_bytes()); // marker 1 from itself
    let fill: &'static [u8] = fill.leak();
    assert_eq!(
        with(&|d| d.stages.as_mut().unwrap().fill = Bytes(fill)),
        StagesLoadError::BadFillNeighbour { marker: 1 }
    );
    let mut radii = rbf_of(&s).radii.0.to_vec();
    radii[8..12].copy_from_slice(&0i32.to_le_bytes());
    let radii: &'static [u8] = radii.leak();
    assert_eq!(
        with(&|d| rbf(d).radii = Bytes(radii)),
        StagesLoadError::BadRadius { marker: 2 }
    );
    let mut alpha = rbf_of(&s).alpha.0.to_vec();
    alpha[36..40].copy_from_slice(&(1i32 << 23).to_le_bytes());
    let alpha: &'static [u8] = alpha.leak();
    assert_eq!(
        with(&|d| rbf(d).alpha = Bytes(alpha)),
        StagesLoadError::AlphaOutOfRange { marker: 3 }
    );
    assert_eq!(
        with(&|d| rbf(d).alpha_shift = 49),
        StagesLoadError::BadShift
    );
    assert_eq!(
        with(&|d| rbf(d).linear_shift = 0),
        StagesLoadError::BadShift
    );
    assert!(matches!(
        with(&|d| rbf(d).radii = Bytes(&[])),
        StagesLoadError::SectionLength {
            section: StagesSection::Radii,
            ..
        }
    ));
}

/// Random bytes written over the stages section (the payload's tail), resealed: loading never
/// panics, and whatever loads plays frames (complete, empty, extreme) without panicking.
#[test]
fn resealed_damage_to_the_stages_never_panics() {
    let blob = &rig().baked.blob;
    let good = *Rig::from_bytes(blob).unwrap().data();
    let without = seal(&RigData {
        stages: None,
        ..good
    });
    let stages_len = blob.len() - without.len() + 1;
    let start = blob.len() - stages_len;
    assert!(start > HEADER_LEN);
    let markers = good.marker_count as usize;
    let frames: [Vec<Option<[i32; 3]>>; 4] = [
        vec![Some([1 << 20, -(1 << 21), 3]); markers],
        vec![None; markers],
        vec![Some([i32::MAX, i32::MIN, 0]); markers],
        (0..markers)
            .map(|m| (m % 3 != 0).then_some([(m as i32) << 22, -(1 << 23), 1 << 24]))
            .collect(),
    ];
    let mut rng = SplitMix64(7);
    let mut loaded = 0;
    for round in 0..4000 {
        let mut c = blob.clone();
        for _ in 0..1 + round % 3 {
            let at = start + (rng.next_u64() % stages_len as u64) as usize;
            c[at] = rng.next_u64() as u8;
        }
        reseal(&mut c);
        if let Ok(rig) = Rig::from_bytes(&c) {
            loaded += 1;
            let mut state = PlayState::new();
            let mut out = vec![[0; 3]; rig.vertex_count()];
            for f in &frames {
                if rig.stages().is_some() {
                    rig.play(&mut state, f, &mut out).unwrap();
                }
            }
        }
    }
    assert!(loaded > 100, "only {loaded} of 4000 damaged stages loaded");
}
