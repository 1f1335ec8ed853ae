//! Scoring surface-aware rigs on a morph-target ground truth (FaceCap): error over the whole
//! skin and over the lip and eyelid bands, and how many lip / eyelid vertices a rig pulls to the
//! other side of the opening.
//!
//! Markers come from a layout (with marker groups), plus the ground truth's static markers on
//! skin no target moves (the back of the head and neck), which act as paper 003's anchors.

use crate::geodesic::{GeodesicMethod, Source};
use crate::ground_truth::{stats, ErrorStats, GroundTruth, GroundTruthError};
use crate::mesh::{distance, SurfacePoint};
use crate::model::{MarkerGroups, PlacedMarker, Side};

use super::geometry::SurfaceGeometry;
use super::masks::{vertex_sides, MaskError, SideRule};
use super::{SurfaceError, SurfaceMarker};

/// Width of the lip and eyelid bands: skin within this edge distance of the opening, metres.
pub const BAND: f64 = 0.008;

/// A ground truth with layout markers, anchors and the lip / eyelid bands.
pub struct Benchmark {
    /// The morph-target truth (mesh, frames, skin); its own markers are not used, except the
    /// static ones as anchors.
    pub truth: GroundTruth,
    /// The markers: layout markers, then anchors.
    pub markers: Vec<SurfaceMarker>,
    /// Where each marker sits on the glTF mesh, to read its position in every frame.
    pub surface: Vec<SurfacePoint>,
    /// Marker groups (layout indices).
    pub groups: Vec<MarkerGroups>,
    /// Per mask (group order): per glTF vertex, its side within [`BAND`] of the mask's
    /// openings on the skin, `None` outside.
    pub bands: Vec<Vec<Option<Side>>>,
}

/// A benchmark could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum BenchmarkError {
    /// The ground truth.
    #[error(transparent)]
    Truth(#[from] GroundTruthError),
    /// Geodesics or masks.
    #[error(transparent)]
    Surface(#[from] SurfaceError),
}

/// Scores of one rig.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Scores {
    /// Over the skin.
    pub whole: ErrorStats,
    /// Per mask band (group order): error over its vertices.
    pub bands: Vec<ErrorStats>,
    /// Per mask band: fraction of its vertices pulled across the opening in the mask's frame.
    pub crossed: Vec<f64>,
}

/// The frame each mask is judged on for crossing: the first that names its opening's target.
fn crossing_frame(truth: &GroundTruth, mask: &str) -> Option<usize> {
    let want = if mask.contains("eye") {
        "blink"
    } else {
        "jaw open"
    };
    truth.frames.iter().position(|f| f.name == want)
}

impl Benchmark {
    /// `truth` with `placed` layout markers (and their `groups`), plus the truth's
    /// `anchors` static markers.
    pub fn new(
        truth: GroundTruth,
        placed: &[PlacedMarker],
        groups: Vec<MarkerGroups>,
        anchors: usize,
    ) -> Result<Self, BenchmarkError> {
        let mesh = &truth.mesh;
        let mut markers: Vec<SurfaceMarker> =
            placed.iter().map(SurfaceMarker::from_placed).collect();
        let mut surface: Vec<SurfacePoint> = placed.iter().map(|p| p.surface).collect();
        let still = truth.marker_vertices.len().saturating_sub(anchors);
        for (a, &v) in truth.marker_vertices[still..].iter().enumerate() {
            let p = mesh.positions[v as usize];
            markers.push(SurfaceMarker {
                name: format!("Anchor_{a}"),
                rest: p,
                source: Source::Vertex(mesh.weld[v as usize]),
                stiffness: 1.0,
            });
            surface.push(SurfacePoint {
                triangle: 0,
                vertices: [v, v, v],
                barycentric: [1.0, 0.0, 0.0],
                point: p,
                distance: 0.0,
            });
        }
        let sources: Vec<Source> = markers.iter().map(|m| m.source).collect();
        let rest: Vec<[f64; 3]> = markers.iter().map(|m| m.rest).collect();
        let geometry = SurfaceGeometry::new(mesh, &sources, GeodesicMethod::EdgeDijkstra)
            .map_err(SurfaceError::from)?;
        let sides = vertex_sides(&groups, &SideRule::Auto, &geometry, &rest, BAND, BAND, 0.0)
            .map_err(|e: MaskError| SurfaceError::from(e))?;
        let bands = sides
            .iter()
            .map(|s| {
                (0..mesh.positions.len())
                    .map(|v| {
                        let x = mesh.weld[v] as usize;
                        let near = s
                            .openings
                            .iter()
                            .any(|&o| geometry.opening_distance[o][x] <= BAND);
                        if near && truth.skin[v] {
                            s.side[v]
                        } else {
                            None
                        }
                    })
                    .collect()
            })
            .collect();
        Ok(Self {
            truth,
            markers,
            surface,
            groups,
            bands,
        })
    }

    /// Marker positions in frame positions `positions`.
    pub fn markers_of(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.surface
            .iter()
            .map(|s| s.interpolate(positions))
            .collect()
    }

    /// Score a rig by running it through the runtime on every frame of the sequence.
    ///
    /// # Panics
    /// If `blob` is not a rig of this scene's mesh and markers (a programming error).
    pub fn score(&self, blob: &[u8]) -> Scores {
        self.score_positions(&self.play(blob))
    }

    /// Run a rig through the runtime on every frame of the sequence: vertex positions per
    /// frame.
    ///
    /// # Panics
    /// If `blob` is not a rig of this scene's mesh and markers (a programming error).
    pub fn play(&self, blob: &[u8]) -> Vec<Vec<[f64; 3]>> {
        let frames: Vec<Vec<[f64; 3]>> = (0..self.truth.frames.len())
            .map(|f| self.truth.positions(f))
            .collect();
        self.play_positions(blob, &frames)
    }

    /// Run a rig through the runtime on the markers read off each of `frames` (positions of
    /// this scene's mesh, glTF vertex order): vertex positions per frame.
    ///
    /// # Panics
    /// If `blob` is not a rig of this scene's mesh and markers (a programming error).
    pub fn play_positions(&self, blob: &[u8], frames: &[Vec<[f64; 3]>]) -> Vec<Vec<[f64; 3]>> {
        let rig = facebake_runtime::Rig::from_bytes(blob).expect("a rig this crate baked");
        let space = rig.space();
        let mut out = vec![[0i32; 3]; rig.vertex_count()];
        frames
            .iter()
            .map(|t| {
                let q: Vec<[i32; 3]> = self
                    .markers_of(t)
                    .iter()
                    .map(|p| {
                        space
                            .to_rig_f64(*p)
                            .expect("markers inside the rig's space")
                    })
                    .collect();
                rig.deform(&q, &mut out).expect("one position per marker");
                out.iter().map(|p| space.to_asset_f64(*p)).collect()
            })
            .collect()
    }

    /// Run a rig through its capture stages on every frame of the sequence, in order, as one
    /// take ([`play_held`], its markers where the truth puts them), each expression held for
    /// `hold` frames: vertex positions per frame. `None` for a rig without stages.
    ///
    /// # Panics
    /// If `blob` is not a rig of this scene's mesh and markers (a programming error).
    pub fn play_stages(&self, blob: &[u8], hold: usize) -> Option<Vec<Vec<[f64; 3]>>> {
        let rig = facebake_runtime::Rig::from_bytes(blob).expect("a rig this crate baked");
        rig.actor_space()?;
        let frames: Vec<Vec<[f64; 3]>> = (0..self.truth.frames.len())
            .map(|f| self.markers_of(&self.truth.positions(f)))
            .collect();
        Some(play_held(&rig, &frames, hold).expect("one position per marker"))
    }

    /// Score predicted positions, one `Vec` per frame of the sequence.
    pub fn score_positions(&self, predicted: &[Vec<[f64; 3]>]) -> Scores {
        let mut whole = Vec::new();
        let mut bands = vec![Vec::new(); self.bands.len()];
        let mut crossed = vec![0.0; self.bands.len()];
        let rest = &self.truth.mesh.positions;
        for (f, got) in predicted.iter().enumerate() {
            let t = self.truth.positions(f);
            self.truth.skin_errors(got, &t, &mut whole);
            for (b, band) in self.bands.iter().enumerate() {
                for (v, side) in band.iter().enumerate() {
                    if side.is_some() {
                        bands[b].push(distance(&got[v], &t[v]));
                    }
                }
                if crossing_frame(&self.truth, &self.groups[b].name) == Some(f) {
                    crossed[b] = crossed_fraction(band, rest, &t, got);
                }
            }
        }
        // FaceCap is in metres.
        Scores {
            whole: stats(&mut whole, 1.0),
            bands: bands.iter_mut().map(|e| stats(e, 1.0)).collect(),
            crossed,
        }
    }
}

/// Two sides count as parted at a vertex when its truth and that of its nearest rest neighbour
/// across the opening are this far apart (metres); closer, "pulled across" means nothing.
pub const PARTED: f64 = 0.002;

/// Fraction of a band's vertices, among those where the opening parts (see [`PARTED`]), pulled
/// across it: nearer (predicted position) to the true position of the nearest rest vertex on
/// the other side than to their own.
pub fn crossed_fraction(
    band: &[Option<Side>],
    rest: &[[f64; 3]],
    truth: &[[f64; 3]],
    got: &[[f64; 3]],
) -> f64 {
    let members: Vec<(usize, Side)> = band
        .iter()
        .enumerate()
        .filter_map(|(v, s)| s.map(|s| (v, s)))
        .collect();
    let mut parted = 0usize;
    let mut across = 0usize;
    for &(v, side) in &members {
        let other = members.iter().filter(|m| m.1 != side).min_by(|a, b| {
            distance(&rest[a.0], &rest[v]).total_cmp(&distance(&rest[b.0], &rest[v]))
        });
        let Some(&(u, _)) = other else { continue };
        if distance(&truth[u], &truth[v]) < PARTED {
            continue;
        }
        parted += 1;
        if distance(&got[v], &truth[u]) < distance(&got[v], &truth[v]) {
            across += 1;
        }
    }
    across as f64 / parted.max(1) as f64
}

/// Marker frames (metres, rig marker order) through `rig`'s capture stages in order, as one take
/// (`Rig::play`, in the rig's actor space), each held for `hold` frames as a face holds an
/// expression (the head refit weighs a marker by its motion since the last frame too, and no
/// take jumps from one expression to the next): vertex positions (asset units) per frame, each
/// the last of its hold. `None` for a rig without stages or frames of another marker count.
pub fn play_held(
    rig: &facebake_runtime::Rig<'_>,
    frames: &[Vec<[f64; 3]>],
    hold: usize,
) -> Option<Vec<Vec<[f64; 3]>>> {
    let (space, actor) = (rig.space(), rig.actor_space()?);
    let mut state = facebake_runtime::PlayState::new();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    frames
        .iter()
        .map(|markers| {
            let q: Vec<Option<[i32; 3]>> =
                markers.iter().map(|p| actor.to_rig_f64(*p).ok()).collect();
            for _ in 0..hold.max(1) {
                rig.play(&mut state, &q, &mut out).ok()?;
            }
            Some(out.iter().map(|p| space.to_asset_f64(*p)).collect())
        })
        .collect()
}
