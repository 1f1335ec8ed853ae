//! Geodesic distance timings: 60 sources on a ~50k-vertex surface with both methods (target:
//! under 1.5 s on the 2-core machine), 40 markers on the Face Cap head, and the Face Cap
//! all-pairs edge-Dijkstra matrix set against the thesis' 547 s for a 2746-vertex face.

use std::path::Path;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use facebake::geodesic::{GeodesicMethod, Geodesics, Source};
use facebake::io::gltf_mesh::load_mesh;
use facebake::mesh::{farthest_point_sampling, Topology};

/// The thesis' time for the geodesic distance matrix of its 2746-vertex face (Table 5.5).
const THESIS_SECONDS: f64 = 547.0;

/// A 224 × 224 height field over the unit square with smooth bumps: 50,176 vertices, one
/// boundary loop (so the heat method takes its averaged Neumann/Dirichlet path).
fn bumpy_grid(n: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let s = 1.0 / (n - 1) as f64;
    let pos = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64 * s, (i / n) as f64 * s);
            let z = 0.05 * (7.0 * x).sin() * (5.0 * y).cos() + 0.02 * (19.0 * (x + y)).sin();
            [x, y, z]
        })
        .collect();
    let tris = facebake::mesh::grid_triangles(n);
    (pos, tris)
}

fn grid_60_sources(c: &mut Criterion) {
    let (pos, tris) = bumpy_grid(224);
    let sources: Vec<Source> = (0..60u32)
        .map(|i| Source::Vertex((i * 836 + 97) % pos.len() as u32))
        .collect();
    let mut group = c.benchmark_group("grid 50176 vertices, 60 sources");
    group.sample_size(10);
    group.bench_function("edge dijkstra", |b| {
        b.iter(|| {
            let g = Geodesics::new(&pos, &tris, GeodesicMethod::EdgeDijkstra).unwrap();
            g.from_sources(&sources).unwrap()
        })
    });
    group.bench_function("heat: factorise + 60 sources", |b| {
        b.iter(|| {
            let g = Geodesics::new(&pos, &tris, GeodesicMethod::Heat).unwrap();
            g.from_sources(&sources).unwrap()
        })
    });
    group.bench_function("heat: factorise only", |b| {
        b.iter(|| Geodesics::new(&pos, &tris, GeodesicMethod::Heat).unwrap())
    });
    let g = Geodesics::new(&pos, &tris, GeodesicMethod::Heat).unwrap();
    group.bench_function("heat: 60 sources, factorised", |b| {
        b.iter(|| g.from_sources(&sources).unwrap())
    });
    group.finish();
}

fn facecap(c: &mut Criterion) {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/FaceCapHeadGeneric.glb"
    ));
    let m = load_mesh(path, Some("head"), None).unwrap();
    let (pos, tris) = (&m.welded_positions, &m.welded_triangles);
    let skin = Topology::new(pos, tris).components.vertices_of(0);
    let markers: Vec<Source> = farthest_point_sampling(pos, &skin, 40, skin[0])
        .unwrap()
        .into_iter()
        .map(Source::Vertex)
        .collect();
    let mut group = c.benchmark_group("facecap head");
    group.sample_size(10);
    for method in [GeodesicMethod::EdgeDijkstra, GeodesicMethod::Heat] {
        group.bench_function(
            format!("{method:?}: setup + 40 markers to every vertex"),
            |b| {
                b.iter(|| {
                    let g = Geodesics::new(pos, tris, method).unwrap();
                    g.from_sources(&markers).unwrap()
                })
            },
        );
    }
    // The thesis' quantity: the full vertex-to-vertex geodesic matrix by shortest edge paths.
    // Every welded vertex as a source gives every row of the glTF-vertex matrix too (the
    // 2694 glTF vertices are copies of these 2659 at UV seams).
    let all: Vec<Source> = (0..pos.len() as u32).map(Source::Vertex).collect();
    let g = Geodesics::new(pos, tris, GeodesicMethod::EdgeDijkstra).unwrap();
    let start = Instant::now();
    let matrix = g.from_sources(&all).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "FaceCap all-pairs edge Dijkstra: {} x {} matrix in {seconds:.3} s; the thesis took \
         {THESIS_SECONDS} s for its 2746-vertex face's matrix: {:.0}x faster",
        matrix.len(),
        pos.len(),
        THESIS_SECONDS / seconds
    );
    group.bench_function("edge dijkstra: all-pairs matrix (the thesis' 547 s)", |b| {
        b.iter(|| g.from_sources(&all).unwrap())
    });
    group.finish();
}

criterion_group!(benches, grid_60_sources, facecap);
criterion_main!(benches);
