//! Ground truth from morph targets: any blend of a mesh's morph targets gives the true position
//! of every vertex, so markers taken at chosen vertices can drive a rig and every other vertex
//! can be scored against the truth.
//!
//! For the FaceCap head (52 ARKit targets) the markers are picked by farthest-point sampling:
//! most on the skin that some target moves (the face), a few on the skin no target moves (back of
//! the head, neck), which pin it like paper 003's static points. The sequence blends several
//! targets at once: named expressions first, then deterministic pseudo-random blends.

use crate::mesh::{farthest_point_sampling, MeshError};
use crate::model::{FaceMesh, LayoutMarker, MarkerAnchor, MarkerLayout};

/// A vertex counts as moving if some morph target moves it further than this (asset units
/// relative to the bounding-box diagonal).
pub const MOVING_FRACTION_OF_DIAGONAL: f64 = 2e-4;

/// Named expressions of the FaceCap sequence: (name, [(target, weight)]).
const EXPRESSIONS: &[(&str, &[(&str, f64)])] = &[
    ("jaw open", &[("jawOpen", 1.0)]),
    ("open funnel", &[("jawOpen", 0.6), ("mouthFunnel", 1.0)]),
    ("blink", &[("eyeBlink_L", 1.0), ("eyeBlink_R", 1.0)]),
    (
        "smile",
        &[
            ("mouthSmile_L", 1.0),
            ("mouthSmile_R", 1.0),
            ("cheekSquint_L", 0.5),
            ("cheekSquint_R", 0.5),
        ],
    ),
    (
        "surprise",
        &[
            ("browInnerUp", 1.0),
            ("browOuterUp_L", 1.0),
            ("browOuterUp_R", 1.0),
            ("eyeWide_L", 0.8),
            ("eyeWide_R", 0.8),
            ("jawOpen", 0.4),
        ],
    ),
    ("pucker", &[("mouthPucker", 1.0), ("jawForward", 0.5)]),
    ("jaw left", &[("jawLeft", 1.0), ("mouthLeft", 0.6)]),
    (
        "frown",
        &[
            ("mouthFrown_L", 1.0),
            ("mouthFrown_R", 1.0),
            ("browDown_L", 0.8),
            ("browDown_R", 0.8),
        ],
    ),
];

/// Pseudo-random blends added after the named expressions.
const RANDOM_BLENDS: usize = 24;
/// Targets mixed in each pseudo-random blend.
const TARGETS_PER_BLEND: usize = 4;

/// The mesh cannot serve as a ground truth.
#[derive(Debug, thiserror::Error)]
pub enum GroundTruthError {
    /// Picking marker vertices failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// No skin vertex is moved by a morph target, or none is still.
    #[error("{}: no {kind} skin vertices to place markers on", path.display())]
    NoVertices {
        /// "moving" or "still".
        kind: &'static str,
        /// The mesh file.
        path: std::path::PathBuf,
    },
}

/// One frame of a ground-truth sequence.
#[derive(Clone, Debug)]
pub struct Frame {
    /// What it shows.
    pub name: String,
    /// Morph target weights.
    pub weights: Vec<(usize, f64)>,
}

/// A mesh with morph targets, markers at vertices, and a sequence of blends.
pub struct GroundTruth {
    /// The mesh.
    pub mesh: FaceMesh,
    /// Marker vertices (glTF order).
    pub marker_vertices: Vec<u32>,
    /// Per glTF vertex: on the largest connected piece (the skin).
    pub skin: Vec<bool>,
    /// The frames.
    pub frames: Vec<Frame>,
}

/// Mean, 99th percentile and maximum of an error, in millimetres.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    /// Mean.
    pub mean_mm: f64,
    /// 99th percentile.
    pub p99_mm: f64,
    /// Maximum.
    pub max_mm: f64,
}

impl std::fmt::Display for ErrorStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mean {:.4} mm, p99 {:.4} mm, max {:.4} mm",
            self.mean_mm, self.p99_mm, self.max_mm
        )
    }
}

/// Error statistics of distances given in asset units, converted with `metres_per_unit`.
pub fn stats(distances: &mut [f64], metres_per_unit: f64) -> ErrorStats {
    if distances.is_empty() {
        return ErrorStats::default();
    }
    distances.sort_by(f64::total_cmp);
    let to_mm = 1000.0 * metres_per_unit;
    let p99_index = ((distances.len() as f64 * 0.99).ceil() as usize).clamp(1, distances.len()) - 1;
    ErrorStats {
        mean_mm: distances.iter().sum::<f64>() / distances.len() as f64 * to_mm,
        p99_mm: distances[p99_index] * to_mm,
        max_mm: distances[distances.len() - 1] * to_mm,
    }
}

/// SplitMix64: a tiny deterministic generator so the sequence is the same everywhere.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl GroundTruth {
    /// Markers and sequence for a mesh with morph targets: `markers` in all, of which
    /// `static_markers` on skin that no target moves.
    pub fn new(
        mesh: FaceMesh,
        markers: usize,
        static_markers: usize,
    ) -> Result<Self, GroundTruthError> {
        // The seen skin: a mouth's bag or an eye's socket joined to it is not skin.
        let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
        let skin: Vec<bool> = mesh
            .weld
            .iter()
            .map(|&w| topo.components.vertex_component[w as usize] == 0)
            .collect();
        let threshold = MOVING_FRACTION_OF_DIAGONAL * mesh.diagonal();
        let moving: Vec<bool> = (0..mesh.positions.len())
            .map(|v| {
                mesh.morph_targets
                    .iter()
                    .any(|t| crate::mesh::norm(&t.deltas[v]) > threshold)
            })
            .collect();
        // One glTF vertex per welded vertex, so seams never give two markers one position.
        let mut seen = vec![false; mesh.welded_positions.len()];
        let mut face = Vec::new();
        let mut still = Vec::new();
        for v in 0..mesh.positions.len() {
            let w = mesh.weld[v] as usize;
            if skin[v] && !seen[w] {
                seen[w] = true;
                if moving[v] {
                    face.push(v as u32)
                } else {
                    still.push(v as u32)
                }
            }
        }
        let nose = *face
            .iter()
            .max_by(|&&a, &&b| {
                mesh.positions[a as usize][2].total_cmp(&mesh.positions[b as usize][2])
            })
            .ok_or_else(|| GroundTruthError::NoVertices {
                kind: "moving",
                path: mesh.source.clone(),
            })?;
        let mut marker_vertices = farthest_point_sampling(
            &mesh.positions,
            &face,
            markers.saturating_sub(static_markers),
            nose,
        )?;
        if static_markers > 0 {
            let back = *still
                .iter()
                .min_by(|&&a, &&b| {
                    mesh.positions[a as usize][2].total_cmp(&mesh.positions[b as usize][2])
                })
                .ok_or_else(|| GroundTruthError::NoVertices {
                    kind: "still",
                    path: mesh.source.clone(),
                })?;
            marker_vertices.extend(farthest_point_sampling(
                &mesh.positions,
                &still,
                static_markers,
                back,
            )?);
        }
        let frames = Self::sequence(&mesh);
        Ok(Self {
            mesh,
            marker_vertices,
            skin,
            frames,
        })
    }

    /// The FaceCap sequence: the named expressions whose targets the mesh has (or has split into
    /// `_L` and `_R` sides), then blends.
    fn sequence(mesh: &FaceMesh) -> Vec<Frame> {
        let mut frames: Vec<Frame> = EXPRESSIONS
            .iter()
            .filter_map(|(name, parts)| {
                // A target the mesh splits into sides (ICT-FaceKit's `browInnerUp_L` and `_R`)
                // stands for the whole one.
                let weights: Option<Vec<Vec<_>>> = parts
                    .iter()
                    .map(|(t, w)| match mesh.morph_index(t) {
                        Some(i) => Some(vec![(i, *w)]),
                        None => ["_L", "_R"]
                            .iter()
                            .map(|side| mesh.morph_index(&format!("{t}{side}")).map(|i| (i, *w)))
                            .collect(),
                    })
                    .collect();
                weights.map(|weights| Frame {
                    name: (*name).to_string(),
                    weights: weights.concat(),
                })
            })
            .collect();
        let live: Vec<usize> = (0..mesh.morph_targets.len())
            .filter(|&i| {
                mesh.morph_targets[i]
                    .deltas
                    .iter()
                    .any(|d| d.iter().any(|x| *x != 0.0))
            })
            .collect();
        let mut rng = SplitMix64(0xFACE_BA4E);
        for b in 0..RANDOM_BLENDS {
            if live.is_empty() {
                break;
            }
            let mut weights: Vec<(usize, f64)> = Vec::new();
            while weights.len() < TARGETS_PER_BLEND.min(live.len()) {
                let t = live[(rng.next_u64() % live.len() as u64) as usize];
                if weights.iter().all(|w| w.0 != t) {
                    weights.push((t, 0.2 + 0.8 * rng.unit()));
                }
            }
            frames.push(Frame {
                name: format!("blend {b}"),
                weights,
            });
        }
        frames
    }

    /// The markers as a layout (names `M00`, `M01`, …, vertex anchors).
    pub fn layout(&self) -> MarkerLayout {
        MarkerLayout {
            source: self.mesh.source.clone(),
            markers: self
                .marker_vertices
                .iter()
                .enumerate()
                .map(|(i, &v)| LayoutMarker {
                    name: format!("M{i:02}"),
                    anchor: MarkerAnchor::Vertex(v),
                    stiffness: 1.0,
                })
                .collect(),
            groups: Vec::new(),
            triangles: None,
        }
    }

    /// Marker names, in layout order.
    pub fn marker_names(&self) -> Vec<String> {
        (0..self.marker_vertices.len())
            .map(|i| format!("M{i:02}"))
            .collect()
    }

    /// True vertex positions of frame `f`.
    pub fn positions(&self, f: usize) -> Vec<[f64; 3]> {
        self.mesh.morphed(&self.frames[f].weights)
    }

    /// Marker positions at the rest pose.
    pub fn marker_rest(&self) -> Vec<[f64; 3]> {
        self.marker_vertices
            .iter()
            .map(|&v| self.mesh.positions[v as usize])
            .collect()
    }

    /// Marker positions of a frame, given its true vertex positions.
    pub fn markers_of(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.marker_vertices
            .iter()
            .map(|&v| positions[v as usize])
            .collect()
    }

    /// Distances between `predicted` and `truth` over the skin vertices, appended to `out`.
    pub fn skin_errors(&self, predicted: &[[f64; 3]], truth: &[[f64; 3]], out: &mut Vec<f64>) {
        for ((p, t), &s) in predicted.iter().zip(truth).zip(&self.skin) {
            if s {
                out.push(crate::mesh::distance(p, t));
            }
        }
    }
}
