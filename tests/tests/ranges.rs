//! `Rig::deform_range`, and `Rig::prepare` + `Rig::deform_chunk`: a face split into chunks, each
//! deformed on its own (as a job system's workers would), gives the same integers as one
//! `Rig::deform`, for every deformer; a range past the last vertex, and a frame table another
//! rig (or none) filled, is an error.

use facebake_runtime::{FrameError, FrameTable, Rig};
use facebake_tests::fixture;

/// The golden rigs of every deformer and the golden marker frames (40 markers).
fn rigs() -> Vec<(&'static str, Vec<u8>)> {
    ["facecap_weights", "facecap_coefficients", "facecap_planar"]
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(fixture(&format!("golden/{n}.fbk"))).expect("golden rig");
            (n, bytes)
        })
        .collect()
}

fn frames(markers: usize) -> Vec<Vec<[i32; 3]>> {
    let bytes = std::fs::read(fixture("golden/facecap_markers.bin")).expect("golden markers");
    bytes
        .chunks_exact(markers * 12)
        .map(|f| {
            f.chunks_exact(12)
                .map(|p| {
                    [0, 1, 2].map(|c| i32::from_le_bytes(p[4 * c..4 * c + 4].try_into().unwrap()))
                })
                .collect()
        })
        .collect()
}

#[test]
fn chunks_equal_the_whole_frame_for_every_deformer() {
    for (name, blob) in rigs() {
        let rig = Rig::from_bytes(&blob).expect("loads");
        let n = rig.vertex_count();
        let mut whole = vec![[0i32; 3]; n];
        let mut split = vec![[0i32; 3]; n];
        for (f, markers) in frames(rig.marker_count()).iter().enumerate() {
            rig.deform(markers, &mut whole).unwrap();
            // Uneven chunks, different for every frame, one of them empty.
            let cuts = [0, (f * 97) % n, n / 2, n / 2, n - 1 - (f * 31) % (n / 4), n];
            let mut cuts = cuts.to_vec();
            cuts.sort_unstable();
            for w in cuts.windows(2) {
                rig.deform_range(markers, w[0], &mut split[w[0]..w[1]])
                    .unwrap();
            }
            assert_eq!(whole, split, "{name}, frame {f}");
            // The same chunks from one prepared table; the degenerate triangles as reported.
            let mut table = FrameTable::new();
            let degenerate = rig.prepare(markers, &mut table).unwrap();
            assert_eq!(degenerate, rig.deform_report(markers, &mut whole).unwrap());
            split.fill([0; 3]);
            for w in cuts.windows(2) {
                rig.deform_chunk(&table, w[0], &mut split[w[0]..w[1]])
                    .unwrap();
            }
            assert_eq!(whole, split, "{name}, frame {f}, prepared");
        }
    }
}

#[test]
fn a_chunk_needs_a_table_this_rig_prepared() {
    let all = rigs();
    let (a, b) = (
        Rig::from_bytes(&all[0].1).unwrap(),
        Rig::from_bytes(&all[1].1).unwrap(),
    );
    let mut out = vec![[0i32; 3]; 10];
    let mut table = FrameTable::new();
    assert_eq!(
        a.deform_chunk(&table, 0, &mut out),
        Err(FrameError::TableMismatch)
    );
    b.prepare(&vec![[0; 3]; b.marker_count()], &mut table)
        .unwrap();
    assert_eq!(
        a.deform_chunk(&table, 0, &mut out),
        Err(FrameError::TableMismatch)
    );
    assert!(matches!(
        a.prepare(&vec![[0; 3]; a.marker_count() + 1], &mut table),
        Err(FrameError::MarkerCount { .. })
    ));
    a.prepare(&vec![[0; 3]; a.marker_count()], &mut table)
        .unwrap();
    assert!(a.deform_chunk(&table, 0, &mut out).is_ok());
    let n = a.vertex_count();
    assert!(matches!(
        a.deform_chunk(&table, n - 5, &mut out),
        Err(FrameError::VertexRange { .. })
    ));
}

#[test]
fn a_range_past_the_last_vertex_is_an_error() {
    let (_, blob) = &rigs()[0];
    let rig = Rig::from_bytes(blob).unwrap();
    let n = rig.vertex_count();
    let markers = vec![[0i32; 3]; rig.marker_count()];
    let mut out = vec![[0i32; 3]; 10];
    assert_eq!(
        rig.deform_range(&markers, n - 5, &mut out),
        Err(FrameError::VertexRange {
            first: n - 5,
            len: 10,
            vertices: n
        })
    );
    assert_eq!(
        rig.deform_range(&markers, usize::MAX, &mut out),
        Err(FrameError::VertexRange {
            first: usize::MAX,
            len: 10,
            vertices: n
        })
    );
    assert!(matches!(
        rig.deform_range(&markers[1..], 0, &mut out),
        Err(FrameError::MarkerCount { .. })
    ));
}
