//! Issue 14, items 5 and 6: the capture stages' per-frame robustness on the reproducers in
//! `fixtures/repro/` and on made-up jumps.
//!
//! * `play_head_markers_collinear.trc`: JawMoCap with the four head markers put on one line in
//!   frames 300–599. The fit used to be reported as good with the face up to 130 mm off; now the
//!   last good fit is held and reported.
//! * `play_lip_swap_undetected.trc`: Mouth_Up and Mouth_Down swapped on frame 500 (38.6 mm face
//!   error, nothing flagged); now both are rejected as jumps and rebuilt.
//! * 3 cm jumps of Chin and of a head marker, made here from the clean take.

use facebake::demo::JAWMOCAP_HEAD_MARKERS;
use facebake::{HeadMarkers, StagesConfig};
use facebake_runtime::{FitFailure, FrameReport, Rig, RigidStatus};
use facebake_tests::{fixture, jawmocap_rig, play_take, JawMoCapRig};

/// The capture golden's rig: default stages with the head markers the reproducers were made
/// for (ForeHead_M/L/R, NoseTop).
fn rig() -> &'static JawMoCapRig {
    static CELL: std::sync::OnceLock<JawMoCapRig> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        jawmocap_rig(&StagesConfig {
            head: HeadMarkers::Named(JAWMOCAP_HEAD_MARKERS.map(str::to_string).to_vec()),
            ..StagesConfig::default()
        })
    })
}

/// A take's frames in the rig's marker order, metres.
fn take(name: &str, rig: &Rig<'_>) -> Vec<Vec<Option<[f64; 3]>>> {
    let capture = facebake::io::capture::read_capture(&fixture(name)).expect("take reads");
    facebake_tests::frames_in_order(&capture, rig.marker_names())
}

/// A play: vertices (metres) and reports, per frame.
type Played = (Vec<Vec<[f64; 3]>>, Vec<FrameReport>);

/// Play `frames`.
fn play(rig: &Rig<'_>, frames: &[Vec<Option<[f64; 3]>>]) -> Played {
    play_take(rig, frames)
}

/// Largest vertex distance (mm) between two plays over `frames`.
fn worst(a: &[Vec<[f64; 3]>], b: &[Vec<[f64; 3]>], frames: std::ops::Range<usize>) -> f64 {
    frames
        .flat_map(|f| {
            a[f].iter()
                .zip(&b[f])
                .map(|(p, q)| 1000.0 * (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt())
        })
        .fold(0.0, f64::max)
}

fn clean() -> &'static Played {
    static CELL: std::sync::OnceLock<Played> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let r = Rig::from_bytes(&rig().baked.blob).unwrap();
        play(&r, &rig().frames)
    })
}

#[test]
fn the_clean_take_trips_no_check() {
    let (_, reports) = clean();
    assert!(reports.iter().all(|r| r.rejected.is_empty()
        && r.head_markers_dropped == 0
        && matches!(r.rigid, RigidStatus::Fitted { head_markers: 4 })));
}

#[test]
fn collinear_current_head_markers_hold_the_fit() {
    let r = Rig::from_bytes(&rig().baked.blob).unwrap();
    let frames = take("repro/play_head_markers_collinear.trc", &r);
    let (faces, reports) = play(&r, &frames);
    for (f, report) in reports.iter().enumerate() {
        if (300..600).contains(&f) {
            assert_eq!(
                report.rigid,
                RigidStatus::Held(FitFailure::Collinear),
                "frame {f}"
            );
        } else {
            assert!(
                matches!(report.rigid, RigidStatus::Fitted { .. }),
                "frame {f}"
            );
        }
    }
    let error = worst(&faces, &clean().0, 300..600);
    println!("collinear head markers, frames 300-599: face within {error:.2} mm of the clean take");
    // Measured 38.9 mm on the default bake (129.87 mm before the check): the held fit is the
    // head's pose of frame 299, and the head keeps moving through the five seconds it is held.
    assert!(error < 42.0, "{error}");
}

#[test]
fn swapped_lips_are_rejected_as_jumps() {
    let r = Rig::from_bytes(&rig().baked.blob).unwrap();
    let frames = take("repro/play_lip_swap_undetected.trc", &r);
    let (faces, reports) = play(&r, &frames);
    let up = r.marker_index("Mouth_Up").unwrap();
    let down = r.marker_index("Mouth_Down").unwrap();
    let swap = &reports[500];
    assert!(
        swap.jumped.contains(up) && swap.jumped.contains(down),
        "{swap:?}"
    );
    assert!(swap.rejected.contains(up) && swap.rebuilt.contains(up));
    assert!(reports[501].rejected.is_empty());
    let error = worst(&faces, &clean().0, 500..501);
    println!("lip swap, frame 500: face within {error:.2} mm of the clean take");
    // Measured 0.48 mm (was 38.61 mm).
    assert!(error < 5.0, "{error}");
}

/// A 3 cm jump of one marker for one frame, in each axis: Chin (caught by the step gate) and
/// every head marker (caught by the head-marker distance check or, for a jump that barely
/// changes the distances, by the fit's residual).
#[test]
fn three_centimetre_jumps_are_rejected() {
    let r = Rig::from_bytes(&rig().baked.blob).unwrap();
    for name in ["Chin", "ForeHead_M", "ForeHead_L", "ForeHead_R", "NoseTop"] {
        let m = r.marker_index(name).unwrap();
        for axis in 0..3 {
            let mut frames = rig().frames.clone();
            let p = frames[700][m].as_mut().unwrap();
            p[axis] += 0.03;
            let (faces, reports) = play(&r, &frames);
            assert!(reports[700].rejected.contains(m), "{name} axis {axis}");
            let error = worst(&faces, &clean().0, 700..701);
            println!("{name} +3 cm on axis {axis}: face within {error:.2} mm of the clean take");
            assert!(error < 5.0, "{name} axis {axis}: {error}");
        }
    }
}
