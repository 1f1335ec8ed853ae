use super::*;
use crate::io::gltf_mesh::tests::head;
use crate::mesh::{centroid, norm};

/// A UV sphere of radius 1: `rings` latitude rings of `segments` vertices, plus the poles.
fn uv_sphere(rings: usize, segments: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut pos = vec![[0.0, 0.0, 1.0]];
    for r in 1..=rings {
        let theta = std::f64::consts::PI * r as f64 / (rings + 1) as f64;
        for s in 0..segments {
            let phi = std::f64::consts::TAU * s as f64 / segments as f64;
            pos.push([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    pos.push([0.0, 0.0, -1.0]);
    let south = (pos.len() - 1) as u32;
    let id = |r: usize, s: usize| (1 + r * segments + s % segments) as u32;
    let mut tris = Vec::new();
    for s in 0..segments {
        tris.push([0, id(0, s), id(0, s + 1)]);
        for r in 0..rings - 1 {
            tris.push([id(r, s), id(r + 1, s), id(r + 1, s + 1)]);
            tris.push([id(r, s), id(r + 1, s + 1), id(r, s + 1)]);
        }
        tris.push([id(rings - 1, s), south, id(rings - 1, s + 1)]);
    }
    (pos, tris)
}

/// An open cylinder of radius 1 around z from 0 to `height`: `rows` rings of `segments`.
fn cylinder(rows: usize, segments: usize, height: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    tube(
        rows,
        segments,
        |_| 1.0,
        |r| height * r as f64 / (rows - 1) as f64,
    )
}

/// A tube around z: `rings` rings of `around` vertices, ring `r` of radius `radius(r)` at
/// height `z(r)`, each quad between rings split along the same diagonal.
pub(crate) fn tube(
    rings: usize,
    around: usize,
    radius: impl Fn(usize) -> f64,
    z: impl Fn(usize) -> f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    for r in 0..rings {
        for k in 0..around {
            let phi = std::f64::consts::TAU * k as f64 / around as f64;
            positions.push([radius(r) * phi.cos(), radius(r) * phi.sin(), z(r)]);
        }
    }
    let id = |r: usize, k: usize| (r * around + k % around) as u32;
    let mut triangles = Vec::new();
    for r in 0..rings - 1 {
        for k in 0..around {
            triangles.push([id(r, k), id(r, k + 1), id(r + 1, k + 1)]);
            triangles.push([id(r, k), id(r + 1, k + 1), id(r + 1, k)]);
        }
    }
    (positions, triangles)
}

fn great_circle(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (na, nb) = (norm(a), norm(b));
    let c = dot(a, b) / (na * nb);
    c.clamp(-1.0, 1.0).acos()
}

/// Length of the shortest path on the unit cylinder: the straight line on the unrolled strip.
fn unrolled(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let mut dphi = (a[1].atan2(a[0]) - b[1].atan2(b[0])).abs();
    if dphi > std::f64::consts::PI {
        dphi = std::f64::consts::TAU - dphi;
    }
    (dphi * dphi + (a[2] - b[2]) * (a[2] - b[2])).sqrt()
}

use crate::mesh::dot;

/// Mean and max relative error of `got` against `exact` over vertices at least `near` from the
/// source (relative error is meaningless at the source itself).
fn relative_errors(got: &[f64], exact: &[f64], near: f64) -> (f64, f64) {
    let errs: Vec<f64> = got
        .iter()
        .zip(exact)
        .filter(|(_, &e)| e >= near)
        .map(|(&g, &e)| (g - e).abs() / e)
        .collect();
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    (mean, errs.iter().copied().fold(0.0, f64::max))
}

/// Compares both methods with `exact` from each source; returns `(mean, max)` per method
/// (Dijkstra first) over all sources, after checking that Dijkstra is never shorter than the
/// exact distance by more than the chord-versus-arc shortening of the mesh's edges allows.
fn compare(
    name: &str,
    pos: &[[f64; 3]],
    tris: &[[u32; 3]],
    sources: &[Source],
    exact: impl Fn(&[f64; 3], &[f64; 3]) -> f64,
) -> [(f64, f64); 2] {
    // On the smooth surface each edge's own shortest path is longer than its chord; a path of
    // chords is at least (shortest chord / path ratio) times the exact distance.
    let topo = Topology::new(pos, tris);
    let chord_ratio = topo
        .edges
        .iter()
        .map(|e| e.length / exact(&pos[e.a as usize], &pos[e.b as usize]))
        .fold(1.0, f64::min);
    assert!(chord_ratio > 0.999 && chord_ratio < 1.0, "{chord_ratio}");
    let mut result = [(0.0, 0.0); 2];
    for (k, method) in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat]
        .into_iter()
        .enumerate()
    {
        let g = Geodesics::new(pos, tris, method).unwrap();
        let fields = g.from_sources(sources).unwrap();
        let (mut mean, mut max) = (0.0, 0.0f64);
        for (source, field) in sources.iter().zip(&fields) {
            let p = g.seeds(0, source).unwrap().point;
            let want: Vec<f64> = pos.iter().map(|q| exact(&p, q)).collect();
            // (From a vertex: a point source sits inside the smooth surface, off its exact
            // distances by the triangle's sag.)
            if method == GeodesicMethod::EdgeDijkstra && matches!(source, Source::Vertex(_)) {
                for (v, (&d, &w)) in field.iter().zip(&want).enumerate() {
                    assert!(d >= w * chord_ratio - 1e-12, "{name} vertex {v}: {d} < {w}");
                }
            }
            let (m, x) = relative_errors(field, &want, 0.2);
            mean += m / sources.len() as f64;
            max = max.max(x);
        }
        println!("{name} {method:?}: mean relative error {mean:.4}, max {max:.4}");
        result[k] = (mean, max);
    }
    result
}

#[test]
fn sphere_accuracy() {
    let (pos, tris) = uv_sphere(49, 100);
    assert_eq!(pos.len(), 4902);
    let sources = [
        Source::Vertex(1 + 24 * 100),     // equator
        Source::Vertex(1 + 10 * 100 + 7), // high latitude
        Source::Vertex(0),                // pole
        Source::Point {
            triangle: 3001,
            barycentric: [0.2, 0.5, 0.3],
        },
    ];
    let [dijkstra, heat] = compare("sphere", &pos, &tris, &sources, great_circle);
    assert!(heat.0 < dijkstra.0, "{heat:?} vs {dijkstra:?}");
    assert!(heat.0 < 0.02 && heat.1 < 0.25, "{heat:?}");
    assert!(dijkstra.0 < 0.1 && dijkstra.1 < 0.6, "{dijkstra:?}");
}

#[test]
fn cylinder_accuracy() {
    let (pos, tris) = cylinder(49, 100, 3.0);
    let sources = [
        Source::Vertex(24 * 100),      // middle
        Source::Vertex(3 * 100 + 50),  // near the bottom rim
        Source::Vertex(48 * 100 + 10), // on the top rim
        Source::Point {
            triangle: 2000,
            barycentric: [0.6, 0.1, 0.3],
        },
    ];
    let [dijkstra, heat] = compare("cylinder", &pos, &tris, &sources, unrolled);
    assert!(heat.0 < dijkstra.0, "{heat:?} vs {dijkstra:?}");
    assert!(heat.0 < 0.02 && heat.1 < 0.25, "{heat:?}");
    assert!(dijkstra.0 < 0.2 && dijkstra.1 < 0.6, "{dijkstra:?}");
}

#[test]
fn flat_grid_dijkstra_never_shorter_than_straight_line() {
    // On a plane the polyhedral and smooth distances are the straight line: edge paths can
    // only be longer, and equal along grid lines.
    let n = 30;
    let pos: Vec<[f64; 3]> = (0..n * n)
        .map(|i| [(i % n) as f64 * 0.1, (i / n) as f64 * 0.1, 0.0])
        .collect();
    let tris = crate::mesh::grid_triangles(n);
    let source = Source::Vertex((15 * n + 12) as u32);
    for method in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat] {
        let g = Geodesics::new(&pos, &tris, method).unwrap();
        let d = &g.from_sources(&[source]).unwrap()[0];
        let p = pos[15 * n + 12];
        let want: Vec<f64> = pos.iter().map(|q| distance(&p, q)).collect();
        if method == GeodesicMethod::EdgeDijkstra {
            for (v, (&d, &w)) in d.iter().zip(&want).enumerate() {
                assert!(d >= w - 1e-12, "vertex {v}: {d} < {w}");
            }
            // Along the row through the source the path is straight; across the grid's
            // diagonals it is at worst the staircase, √2 times the straight line.
            assert!((d[15 * n + 2] - 1.0).abs() < 1e-12, "{}", d[15 * n + 2]);
            for (v, (&d, &w)) in d.iter().zip(&want).enumerate() {
                assert!(d <= 2f64.sqrt() * w + 1e-12, "vertex {v}: {d} vs {w}");
            }
        }
        let (mean, max) = relative_errors(d, &want, 0.2);
        println!("plane {method:?}: mean relative error {mean:.4}, max {max:.4}");
        if method == GeodesicMethod::Heat {
            assert!(mean < 0.025 && max < 0.15, "{mean} {max}");
        }
    }
}

#[test]
fn point_source_at_a_corner_equals_vertex_source() {
    let (pos, tris) = uv_sphere(20, 40);
    for method in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat] {
        let g = Geodesics::new(&pos, &tris, method).unwrap();
        let t = tris[300];
        let fields = g
            .from_sources(&[
                Source::Vertex(t[1]),
                Source::Point {
                    triangle: 300,
                    barycentric: [0.0, 2.0, 0.0],
                },
            ])
            .unwrap();
        for (a, b) in fields[0].iter().zip(&fields[1]) {
            assert!((a - b).abs() < 1e-9, "{method:?}: {a} vs {b}");
        }
        assert_eq!(fields[0][t[1] as usize], 0.0);
    }
}

/// Markers on the upper and lower lip: the two vertices of the lip opening on the midline.
fn lip_markers(g: &Geodesics) -> (Source, Source) {
    let m = head();
    let loops = g.topology().loops_of(0);
    // The opening below the eyes: the lowest of the three loops in front.
    let mouth = loops[1..]
        .iter()
        .min_by(|a, b| {
            let (ca, cb) = (
                centroid(&m.welded_positions, &a.vertices),
                centroid(&m.welded_positions, &b.vertices),
            );
            ca[1].total_cmp(&cb[1])
        })
        .unwrap();
    let mut midline: Vec<u32> = mouth
        .vertices
        .iter()
        .copied()
        .filter(|&v| m.welded_positions[v as usize][0].abs() < 1e-9)
        .collect();
    midline.sort_by(|&a, &b| {
        m.welded_positions[b as usize][1].total_cmp(&m.welded_positions[a as usize][1])
    });
    assert_eq!(midline.len(), 2, "{midline:?}");
    (Source::Vertex(midline[0]), Source::Vertex(midline[1]))
}

#[test]
fn facecap_lips_are_far_apart_along_the_surface() {
    let m = head();
    for method in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat] {
        let g = Geodesics::new(&m.welded_positions, &m.welded_triangles, method).unwrap();
        let (upper, lower) = lip_markers(&g);
        assert_eq!(g.component_of(&upper).unwrap(), 0);
        assert_eq!(g.component_of(&lower).unwrap(), 0);
        let d = g.between(&[upper, lower]).unwrap();
        let (pu, pl) = (g.seeds(0, &upper).unwrap(), g.seeds(1, &lower).unwrap());
        let straight = distance(&pu.point, &pl.point);
        println!(
            "{method:?}: lips {:.2} mm apart straight, {:.1} mm along the skin",
            1e3 * straight,
            1e3 * d[0][1]
        );
        // Around a mouth corner rather than across the opening.
        // The lips touch: a fraction of a millimetre apart straight, centimetres round.
        assert!(straight < 1e-3, "{straight}");
        assert!(d[0][1] > 0.03 && d[1][0] > 0.03, "{d:?}");
    }
}

#[test]
fn facecap_interior_pieces_are_unreachable_from_skin() {
    let m = head();
    let g = Geodesics::new(
        &m.welded_positions,
        &m.welded_triangles,
        GeodesicMethod::Heat,
    )
    .unwrap();
    let dj = Geodesics::new(
        &m.welded_positions,
        &m.welded_triangles,
        GeodesicMethod::EdgeDijkstra,
    )
    .unwrap();
    // A sixth of the face's edges face two obtuse angles and are flipped for the Laplacian.
    assert!(
        g.heat_flipped_edges().unwrap() > 1000,
        "{:?}",
        g.heat_flipped_edges()
    );
    assert_eq!(dj.heat_flipped_edges(), None);
    let comps = &g.topology().components;
    let skin = comps.vertices_of(0);
    let inside = comps.vertices_of(1)[0];
    let sources = [Source::Vertex(skin[100]), Source::Vertex(inside)];
    let unreachable = g.unreachable(&sources[0]).unwrap();
    assert_eq!(unreachable.len(), 15);
    assert_eq!(
        unreachable[0],
        UnreachableComponent {
            component: 1,
            vertex_count: 166
        }
    );
    assert_eq!(unreachable[0].to_string(), "component 1 (166 vertices)");
    assert_eq!(
        unreachable.iter().map(|u| u.vertex_count).sum::<usize>(),
        2659 - 1919
    );
    assert_eq!(g.unreachable(&sources[1]).unwrap()[0].component, 0);
    for geo in [&g, &dj] {
        let fields = geo.from_sources(&sources).unwrap();
        for (s, field) in fields.iter().enumerate() {
            let own = if s == 0 { 0 } else { 1 };
            for (v, d) in field.iter().enumerate() {
                let same = comps.vertex_component[v] == own;
                assert_eq!(d.is_finite(), same, "source {s} vertex {v}: {d}");
            }
        }
    }
}

#[test]
fn facecap_marker_matrix_is_symmetric() {
    let m = head();
    let comps = Topology::new(&m.welded_positions, &m.welded_triangles).components;
    let skin = comps.vertices_of(0);
    let mut sources: Vec<Source> = skin
        .iter()
        .step_by(97)
        .map(|&v| Source::Vertex(v))
        .collect();
    let on_skin = m
        .welded_triangles
        .iter()
        .position(|t| t[0] == skin[500])
        .unwrap();
    sources.push(Source::Point {
        triangle: on_skin,
        barycentric: [0.3, 0.3, 0.4],
    });
    let n = sources.len();
    // (method, largest and mean relative difference between d[i][j] and d[j][i])
    for (method, max_tolerance, mean_tolerance) in [
        (GeodesicMethod::EdgeDijkstra, 1e-12, 1e-12),
        (GeodesicMethod::Heat, 0.15, 0.03),
    ] {
        let g = Geodesics::new(&m.welded_positions, &m.welded_triangles, method).unwrap();
        let d = g.between(&sources).unwrap();
        let (mut worst, mut mean) = (0.0f64, 0.0);
        // The heat method is zero at the source before negative values are clipped.
        let h = g.heat_time().map_or(0.0, f64::sqrt);
        for (i, row) in d.iter().enumerate() {
            assert!(
                row[i].abs() <= 0.05 * h + 1e-12,
                "{method:?} {i}: {}",
                row[i]
            );
            for (j, &dij) in row.iter().enumerate().take(i) {
                let rel = (dij - d[j][i]).abs() / dij.max(d[j][i]);
                assert!(rel.is_finite(), "{method:?} {i} {j}");
                worst = worst.max(rel);
                mean += rel / (n * (n - 1) / 2) as f64;
            }
        }
        println!("{method:?}: marker matrix asymmetry at most {worst:.2e}, mean {mean:.2e}");
        assert!(
            worst <= max_tolerance && mean <= mean_tolerance,
            "{method:?}: {worst} {mean}"
        );
    }
}

#[test]
fn bad_meshes_and_sources_are_errors() {
    let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert_eq!(
        Geodesics::new(&pos, &[[0, 1, 3]], GeodesicMethod::Heat).unwrap_err(),
        GeodesicError::TriangleVertexOutOfRange {
            triangle: 0,
            vertex: 3,
            vertex_count: 3
        }
    );
    let nan = [[0.0, 0.0, 0.0], [1.0, f64::NAN, 0.0], [0.0, 1.0, 0.0]];
    assert!(matches!(
        Geodesics::new(&nan, &[[0, 1, 2]], GeodesicMethod::EdgeDijkstra),
        Err(GeodesicError::NonFinitePosition { vertex: 1, .. })
    ));
    let g = Geodesics::new(&pos, &[[0, 1, 2]], GeodesicMethod::Heat).unwrap();
    let point = |triangle, barycentric| Source::Point {
        triangle,
        barycentric,
    };
    let cases = [
        (
            Source::Vertex(7),
            GeodesicError::SourceVertexOutOfRange {
                source_index: 1,
                vertex: 7,
                vertex_count: 3,
            },
        ),
        (
            point(1, [1.0, 0.0, 0.0]),
            GeodesicError::SourceTriangleOutOfRange {
                source_index: 1,
                triangle: 1,
                triangle_count: 1,
            },
        ),
        (
            point(0, [1.0, -0.5, 0.0]),
            GeodesicError::BadBarycentric {
                source_index: 1,
                barycentric: [1.0, -0.5, 0.0],
            },
        ),
        (
            point(0, [0.0; 3]),
            GeodesicError::BadBarycentric {
                source_index: 1,
                barycentric: [0.0; 3],
            },
        ),
    ];
    for (bad, want) in cases {
        assert_eq!(g.from_sources(&[Source::Vertex(0), bad]).unwrap_err(), want);
        assert_eq!(g.between(&[Source::Vertex(0), bad]).unwrap_err(), want);
    }
    assert!(g.from_sources(&[]).unwrap().is_empty());
}

#[test]
fn degenerate_triangles_and_isolated_vertices() {
    // A unit square (0,1,2,3), a vertex 4 hanging off corner 2 through a collinear (zero-area)
    // triangle, a triangle with a repeated corner, and an isolated vertex 5.
    let pos = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 2.0, 0.0],
        [9.0, 9.0, 9.0],
    ];
    let tris = [[0, 1, 2], [0, 2, 3], [1, 2, 4], [2, 2, 3]];
    let s2 = 2f64.sqrt();
    for method in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat] {
        let g = Geodesics::new(&pos, &tris, method).unwrap();
        let sources = [
            Source::Vertex(0),
            Source::Vertex(4),
            Source::Point {
                triangle: 2,
                barycentric: [0.0, 0.0, 1.0],
            },
            Source::Vertex(5),
        ];
        let d = g.from_sources(&sources).unwrap();
        // From corner 0: the square, then on to vertex 4 along the hanging edge.
        assert!((d[0][2] - s2).abs() < 0.1 * s2, "{method:?} {:?}", d[0]);
        assert!(
            (d[0][4] - d[0][2] - 1.0).abs() < 1e-12,
            "{method:?} {:?}",
            d[0]
        );
        assert_eq!(d[0][5], f64::INFINITY);
        // From the vertex with no area of its own: edge paths.
        assert_eq!(d[1][..5], [1.0 + s2, 2.0, 1.0, 2.0, 0.0]);
        assert_eq!(d[1], d[2]);
        // The isolated vertex reaches only itself.
        assert_eq!(d[3][5], 0.0);
        assert!(d[3][..5].iter().all(|d| d.is_infinite()));
        assert_eq!(g.unreachable(&sources[3]).unwrap().len(), 1);
    }
}
