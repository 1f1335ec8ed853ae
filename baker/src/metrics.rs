//! Structure metrics: what a mean error hides. Per frame, and worst over a take:
//!
//! * **static drift**: the largest displacement (mm) of the static region, the skin no
//!   expression should move (cranium, back of the head, neck, ears);
//! * **lip aperture**: upper-to-lower lip distance across the mouth opening, over pairs of rim
//!   vertices paired at rest; with a truth, the worst |aperture − true aperture|, else the
//!   widest aperture;
//! * **eyelid closure**: the same across each eye opening;
//! * **edge stretch**: the largest ratio of an edge's deformed length to its rest length (with a
//!   truth: to the larger of its rest and true lengths) over the skin's edges, and how many
//!   edges are stretched beyond 2×. Without a truth, on a mesh with morph targets, beside it:
//!   the largest ratio to the longest the mesh's own targets (each at full weight) or its rest
//!   make the edge, which says whether a stretch is one the asset itself makes;
//! * **flipped triangles**: skin triangles whose normal turned against its rest normal (with a
//!   truth: and whose true normal did not); degenerate triangles (zero area at rest) have no
//!   normal to turn and are left out. Without a truth, on a mesh with morph targets, beside
//!   it: how many of them none of the mesh's own targets (at full weight) turns over
//!   (ICT-FaceKit's rehearsal through its capture rig turns one triangle at a mouth corner
//!   over, and the head's own `jawOpen` turns it over too).
//!
//! With a truth, what the truth itself does is not a fault: FaceCap's own `jawOpen` stretches
//! an inner-lip edge 18.6× from rest and turns 6 skin triangles over. Without one, the second
//! stretch figure says the same of the asset's shapes: ICT-FaceKit's `jawOpen` stretches a
//! 0.066 mm edge at each mouth corner 34×; JawMoCap placed on that head stretches it 3.82×, and
//! no edge beyond 1.42× of the longest the head's own shapes make it. The bars count the first
//! figure. The skin is the largest
//! connected piece; other pieces (FaceCap's mouth bag, teeth and tongue, hidden behind the
//! lips) are not measured, nor is a mouth bag joined to the lips (`openings::closed_mouth`).
//!
//! The regions are found once per mesh ([`Regions`]) and reused for every frame.
//!
//! Openings are the skin's boundary loops less the longest (see
//! [`skin_openings`]). With y up: the mouth is the
//! lowest opening, the eyes the two highest above it; with exactly two openings side by side
//! (centres further apart across than up and down) they are eyes and the mouth is closed.
//! Openings of fewer than [`MIN_OPENING_VERTICES`] vertices are ignored. A rim is split at its
//! two x-extremes (the corners) into an upper and a lower chain; each upper vertex is paired
//! with the lower vertex nearest in x.
//!
//! The static region: on a mesh with morph targets, the skin vertices no target moves (by more
//! than [`MOVING_FRACTION_OF_DIAGONAL`](crate::ground_truth::MOVING_FRACTION_OF_DIAGONAL) of the
//! diagonal, the ground truth's rule). Without morph targets it is geometric: skin vertices
//! farther than [`STATIC_SPACING_FACTOR`] × the mean marker spacing (mean distance from a marker
//! to its nearest other marker) from every marker that is not a head marker, less the throat
//! under the jaw ([`throat`]), which a jaw open moves. Without markers it is empty.

use crate::mesh::{cross, distance, dot, norm, sub, Topology};
use crate::model::FaceMesh;
use crate::openings::{skin_openings, Opening};

/// A skin triangle lower than this fraction of its longest edge is degenerate: it has no
/// orientation at rest, so it is not counted among the flipped triangles (FaceCap has none:
/// its flattest skin triangle is 0.16 mm high, 7 % of its longest edge).
pub const DEGENERATE_HEIGHT_FRACTION: f64 = 1e-6;

/// Openings with fewer rim vertices are not mouth or eyes.
pub const MIN_OPENING_VERTICES: usize = 6;

/// Geometric static rule: skin farther than this many mean marker spacings from every face
/// (non-head) marker is static.
pub const STATIC_SPACING_FACTOR: f64 = 2.5;

/// Geometric static rule: skin under the mouth (up to one mean marker spacing above its
/// height, as the jaw's angle is), between the jaw's sides and within this many spacings of a
/// marker under the mouth is the jaw's and the throat's ([`throat`]), not static, however far
/// from the markers. Measured against the morph-target rule's truth (`docs/measurements.md`,
/// "The static region of a mesh without morph targets"): ICT-FaceKit's expressions move skin
/// that the rule without it calls static by up to 19.4 mm (under the chin, 5 cm behind it),
/// 2459 vertices by over 1 mm; with it by 3.2 mm (the jaw's angle, which ICT's own shapes move),
/// 1862; FaceCap's 5.4 → 3.4 mm (its temple), 11 → 3 vertices over 1 mm, 670 → 656 static.
pub const THROAT_SPACING_FACTOR: f64 = 6.0;

/// An edge counts as over-stretched beyond this ratio.
pub const STRETCH_LIMIT: f64 = 2.0;

/// The regions could not be found.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MetricsError {
    /// A triangle names a vertex the positions lack.
    #[error("triangle {triangle} names vertex {vertex}, but there are {count} vertices")]
    BadTriangle {
        /// The triangle.
        triangle: usize,
        /// The vertex.
        vertex: u32,
        /// Vertices given.
        count: usize,
    },
    /// A static vertex is out of range.
    #[error("static vertex {vertex} is beyond the {count} vertices")]
    BadStaticVertex {
        /// The vertex.
        vertex: u32,
        /// Vertices given.
        count: usize,
    },
}

/// How the static region was chosen.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub enum StaticRule {
    /// Skin vertices no morph target moves.
    MorphTargets,
    /// Skin vertices far from every face marker (see the module docs).
    FarFromMarkers {
        /// The distance, mesh units.
        distance: f64,
    },
    /// Given by the caller.
    Given,
    /// None: the mesh has no morph targets and no face markers were given to find it by.
    NoMarkers,
}

/// Rim vertex pairs across one opening: (upper, lower), vertex ids of the input positions.
pub type RimPairs = Vec<[u32; 2]>;

/// The regions of a mesh the metrics look at, found once.
#[derive(Clone, Debug)]
pub struct Regions {
    /// Vertices of the mesh.
    pub vertex_count: usize,
    /// The static region.
    pub static_vertices: Vec<u32>,
    /// How it was chosen.
    pub static_rule: StaticRule,
    /// Pairs across the mouth (empty: no mouth opening).
    pub lips: RimPairs,
    /// Pairs across each eye opening.
    pub eyes: Vec<RimPairs>,
    /// Every skin edge once (seam duplicates welded).
    pub edges: Vec<[u32; 2]>,
    /// The skin triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Millimetres per mesh unit (1000 for metres).
    pub mm_per_unit: f64,
    rest: Vec<[f64; 3]>,
    /// Per edge of [`Regions::edges`], the longest the mesh's own shapes make it: its rest
    /// length, or its length in a morph target at full weight if longer (`None`: no targets).
    longest: Option<Vec<f64>>,
    /// Per triangle of [`Regions::triangles`], whether a morph target at full weight turns it
    /// over (`None`: no targets).
    shapes_turn: Option<Vec<bool>>,
}

/// One opening's aperture in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Aperture {
    /// The widest gap across the opening, mm.
    pub widest_mm: f64,
    /// The widest true gap, mm (with a truth).
    pub truth_widest_mm: Option<f64>,
    /// The worst |gap − true gap| over the pairs, mm (with a truth).
    pub error_mm: Option<f64>,
}

impl Aperture {
    /// The figure that judges it: the error with a truth, else the widest gap.
    pub fn figure_mm(&self) -> f64 {
        self.error_mm.unwrap_or(self.widest_mm)
    }
}

/// The structure metrics of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameMetrics {
    /// Largest displacement of the static region from rest, mm (0 without one).
    pub static_drift_mm: f64,
    /// Whether there was a static region to measure (a mesh without morph targets needs
    /// markers to find it, [`StaticRule::NoMarkers`]).
    pub static_measured: bool,
    /// Across the mouth (`None`: no mouth opening).
    pub lips: Option<Aperture>,
    /// Across the eyes, both together (`None`: no eye openings).
    pub eyelids: Option<Aperture>,
    /// Largest deformed / rest edge length.
    pub max_stretch: f64,
    /// Without a truth, on a mesh with morph targets: the largest deformed length over the
    /// longest the mesh's own targets (or its rest) make the edge.
    pub beyond_shapes: Option<f64>,
    /// Edges stretched beyond [`STRETCH_LIMIT`].
    pub edges_over_limit: usize,
    /// Triangles whose normal turned against the rest normal.
    pub flipped: usize,
    /// Without a truth, on a mesh with morph targets: of [`FrameMetrics::flipped`], the
    /// triangles that none of the mesh's own targets (at full weight) turns over.
    pub flipped_beyond_shapes: Option<usize>,
}

/// The worst of each metric over a take, with the frame it happened in.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TakeMetrics {
    /// Frames measured.
    pub frames: usize,
    /// Whether the frames were measured against a truth (the lip and eyelid figures are then
    /// errors, else apertures).
    pub against_truth: bool,
    /// Worst static drift, mm, and its frame.
    pub static_drift_mm: (f64, usize),
    /// Whether any frame had a static region to measure.
    pub static_measured: bool,
    /// Worst lip figure (error with a truth, else widest aperture), mm, and its frame.
    pub lips_mm: Option<(f64, usize)>,
    /// Worst eyelid figure, mm, and its frame.
    pub eyelids_mm: Option<(f64, usize)>,
    /// Largest stretch and its frame.
    pub max_stretch: (f64, usize),
    /// Largest stretch beyond the mesh's own shapes and its frame (see
    /// [`FrameMetrics::beyond_shapes`]).
    pub beyond_shapes: Option<(f64, usize)>,
    /// Most edges over the limit in one frame, and that frame.
    pub edges_over_limit: (usize, usize),
    /// Frames with some edge over the limit.
    pub frames_over_limit: usize,
    /// Most flipped triangles in one frame, and that frame.
    pub flipped: (usize, usize),
    /// Most flipped triangles in one frame that the mesh's own shapes do not turn over, and
    /// that frame (see [`FrameMetrics::flipped_beyond_shapes`]).
    pub flipped_beyond_shapes: Option<(usize, usize)>,
}

fn worse<T: PartialOrd + Copy>(best: &mut (T, usize), value: T, frame: usize) {
    if value > best.0 {
        *best = (value, frame);
    }
}

impl TakeMetrics {
    /// The worst over `frames` (in take order).
    pub fn of(frames: &[FrameMetrics]) -> Self {
        let mut t = Self {
            frames: frames.len(),
            ..Self::default()
        };
        for (f, m) in frames.iter().enumerate() {
            worse(&mut t.static_drift_mm, m.static_drift_mm, f);
            t.static_measured |= m.static_measured;
            t.against_truth |= m.lips.or(m.eyelids).is_some_and(|a| a.error_mm.is_some());
            for (slot, a) in [(&mut t.lips_mm, m.lips), (&mut t.eyelids_mm, m.eyelids)] {
                if let Some(a) = a {
                    worse(slot.get_or_insert((0.0, f)), a.figure_mm(), f);
                }
            }
            worse(&mut t.max_stretch, m.max_stretch, f);
            if let Some(b) = m.beyond_shapes {
                worse(t.beyond_shapes.get_or_insert((0.0, f)), b, f);
            }
            worse(&mut t.edges_over_limit, m.edges_over_limit, f);
            worse(&mut t.flipped, m.flipped, f);
            if let Some(n) = m.flipped_beyond_shapes {
                worse(t.flipped_beyond_shapes.get_or_insert((0, f)), n, f);
            }
            t.frames_over_limit += usize::from(m.edges_over_limit > 0);
        }
        t
    }
}

/// What the metrics say in place of the static drift when there was no static region.
const NO_STATIC_REGION: &str = "static drift not measured (no static region)";

fn aperture_text(name: &str, a: Option<Aperture>) -> String {
    match a {
        None => format!("{name} -"),
        Some(Aperture {
            error_mm: Some(e),
            widest_mm,
            truth_widest_mm,
        }) => format!(
            "{name} off by {e:.1} mm (widest {widest_mm:.1}, true {:.1})",
            truth_widest_mm.unwrap_or(0.0)
        ),
        Some(a) => format!("{name} open {:.1} mm", a.widest_mm),
    }
}

impl std::fmt::Display for FrameMetrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}, {}, {}, stretch {:.2}× ({} edges > {STRETCH_LIMIT}×{}), {} flipped{}",
            if self.static_measured {
                format!("static drift {:.2} mm", self.static_drift_mm)
            } else {
                NO_STATIC_REGION.to_string()
            },
            aperture_text("lips", self.lips),
            aperture_text("eyelids", self.eyelids),
            self.max_stretch,
            self.edges_over_limit,
            self.beyond_shapes.map_or(String::new(), |b| format!(
                "; {b:.2}× its own shapes' longest"
            )),
            self.flipped,
            self.flipped_beyond_shapes
                .filter(|_| self.flipped > 0)
                .map_or(String::new(), |n| format!(
                    " ({n} that its own shapes do not turn over)"
                ))
        )
    }
}

impl std::fmt::Display for TakeMetrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let how = if self.against_truth {
            "off by up to"
        } else {
            "open at most"
        };
        let opening = |v: Option<(f64, usize)>| {
            v.map_or("-".to_string(), |(x, fr)| {
                format!("{how} {x:.1} mm (frame {fr})")
            })
        };
        let edges = match self.edges_over_limit {
            (0, _) => format!("no edge over {STRETCH_LIMIT}×"),
            (n, fr) => format!(
                "edges over {STRETCH_LIMIT}×: up to {n} (frame {fr}) in {} of {} frames",
                self.frames_over_limit, self.frames
            ),
        };
        let flips = match (self.flipped, self.flipped_beyond_shapes) {
            ((0, _), _) => "no flipped triangle".to_string(),
            ((n, fr), None) => format!("flipped up to {n} (frame {fr})"),
            ((n, fr), Some((0, _))) => format!(
                "flipped up to {n} (frame {fr}; each one its own shapes turn over too)"
            ),
            ((n, fr), Some((b, bf))) => format!(
                "flipped up to {n} (frame {fr}; up to {b} that its own shapes do not turn over, frame {bf})"
            ),
        };
        let drift = if self.static_measured {
            format!(
                "static drift {:.2} mm (frame {})",
                self.static_drift_mm.0, self.static_drift_mm.1
            )
        } else {
            NO_STATIC_REGION.to_string()
        };
        let shapes = self.beyond_shapes.map_or(String::new(), |(x, fr)| {
            format!("; {x:.2}× its own shapes' longest, frame {fr}")
        });
        write!(
            f,
            "{drift}, lips {}, eyelids {}, stretch {:.2}× (frame {}{shapes}), {edges}, {flips}",
            opening(self.lips_mm),
            opening(self.eyelids_mm),
            self.max_stretch.0,
            self.max_stretch.1,
        )
    }
}

/// The face's own axes from the skin's openings on `welded` (`topology` its seen topology),
/// and the openings with their centres in those axes.
fn face_openings(
    topology: &Topology,
    welded: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> (crate::frame::FaceFrame, Vec<Opening>) {
    let openings = skin_openings(topology, welded, triangles);
    let frame = crate::frame::FaceFrame::from_openings(&openings, crate::mesh::mean(welded));
    let local = openings
        .into_iter()
        .map(|o| Opening {
            centre: frame.local(&o.centre),
            ..o
        })
        .collect();
    (frame, local)
}

/// Skin vertices (largest connected piece) of `rest`/`triangles`, per input vertex.
fn skin_of(weld: &[u32], topology: &Topology) -> Vec<bool> {
    weld.iter()
        .map(|&w| topology.components.vertex_component[w as usize] == 0)
        .collect()
}

/// The mouth and the eyes among `openings` (see the module docs): (mouth, eyes).
fn mouth_and_eyes(openings: &[Opening]) -> (Option<&Opening>, Vec<&Opening>) {
    let mut list: Vec<&Opening> = openings
        .iter()
        .filter(|o| o.vertices.len() >= MIN_OPENING_VERTICES)
        .collect();
    list.sort_by(|a, b| a.centre[1].total_cmp(&b.centre[1]));
    if let [a, b] = list.as_slice() {
        let across = (a.centre[0] - b.centre[0]).abs();
        if across > (a.centre[1] - b.centre[1]).abs() {
            return (None, list);
        }
    }
    let Some((mouth, rest)) = list.split_first() else {
        return (None, Vec::new());
    };
    let eyes = rest.iter().rev().take(2).copied().collect();
    (Some(mouth), eyes)
}

/// Pairs across an opening's rim (welded ids): corners at its x-extremes, upper chain paired to
/// the lower vertex nearest in x.
fn rim_pairs(rim: &[u32], welded: &[[f64; 3]]) -> Vec<[u32; 2]> {
    let x = |v: u32| welded[v as usize][0];
    let (lo, hi) = crate::mesh::x_extremes(rim, welded);
    let n = rim.len();
    let chain = |from: usize, to: usize| -> Vec<u32> {
        let mut out = Vec::new();
        let mut i = (from + 1) % n;
        while i != to {
            out.push(rim[i]);
            i = (i + 1) % n;
        }
        out
    };
    let (a, b) = (chain(lo, hi), chain(hi, lo));
    let mean_y =
        |c: &[u32]| c.iter().map(|&v| welded[v as usize][1]).sum::<f64>() / c.len().max(1) as f64;
    let (upper, lower) = if mean_y(&a) >= mean_y(&b) {
        (a, b)
    } else {
        (b, a)
    };
    upper
        .iter()
        .filter_map(|&u| {
            lower
                .iter()
                .min_by(|&&p, &&q| (x(p) - x(u)).abs().total_cmp(&(x(q) - x(u)).abs()))
                .map(|&l| [u, l])
        })
        .collect()
}

impl Regions {
    /// The regions of a mesh given as plain data: `rest` positions, `triangles` over them and
    /// the static region's vertices (`rule` says how they were chosen). Vertices with equal
    /// positions are welded to find the topology; results name input vertices.
    pub fn new(
        rest: &[[f64; 3]],
        triangles: &[[u32; 3]],
        static_vertices: Vec<u32>,
        rule: StaticRule,
    ) -> Result<Self, MetricsError> {
        let count = rest.len();
        for (i, t) in triangles.iter().enumerate() {
            if let Some(&v) = t.iter().find(|&&v| v as usize >= count) {
                return Err(MetricsError::BadTriangle {
                    triangle: i,
                    vertex: v,
                    count,
                });
            }
        }
        if let Some(&v) = static_vertices.iter().find(|&&v| v as usize >= count) {
            return Err(MetricsError::BadStaticVertex { vertex: v, count });
        }
        let (weld, welded) = crate::model::weld_pieces(rest, triangles);
        let mut original = vec![0u32; welded.len()];
        for (v, &w) in weld.iter().enumerate().rev() {
            original[w as usize] = v as u32;
        }
        let welded_triangles: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| weld[v as usize]))
            .collect();
        let topology = crate::openings::seen_topology(&welded, &welded_triangles);
        // Read in the face's own axes: the mouth below the eyes, its rims paired across it.
        let (frame, openings) = face_openings(&topology, &welded, &welded_triangles);
        let welded = frame.points(&welded);
        let (mouth, eyes) = mouth_and_eyes(&openings);
        let to_input = |pairs: Vec<[u32; 2]>| -> RimPairs {
            pairs
                .into_iter()
                .map(|p| p.map(|w| original[w as usize]))
                .collect()
        };
        let lips = mouth.map_or_else(Vec::new, |m| to_input(rim_pairs(&m.vertices, &welded)));
        let eyes = eyes
            .iter()
            .map(|e| to_input(rim_pairs(&e.vertices, &welded)))
            .collect();
        let on_skin = |w: u32| topology.components.vertex_component[w as usize] == 0;
        let edges: Vec<[u32; 2]> = topology
            .edges
            .iter()
            .filter(|e| on_skin(e.a))
            .map(|e| [original[e.a as usize], original[e.b as usize]])
            .collect();
        let triangles = triangles
            .iter()
            .filter(|t| t.iter().all(|&v| on_skin(weld[v as usize])) && has_orientation(rest, t))
            .copied()
            .collect();
        Ok(Self {
            vertex_count: count,
            static_vertices,
            static_rule: rule,
            lips,
            eyes,
            edges,
            triangles,
            mm_per_unit: 1000.0,
            rest: rest.to_vec(),
            longest: None,
            shapes_turn: None,
        })
    }

    /// The regions of a loaded mesh: the static region from its morph targets if it has any,
    /// else from the markers (`markers` rest positions; `head` indexes the head markers, which
    /// do not count as face markers). Vertex ids are glTF ids.
    pub fn for_mesh(
        mesh: &FaceMesh,
        markers: &[[f64; 3]],
        head: &[usize],
    ) -> Result<Self, MetricsError> {
        let topology =
            crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
        let skin = skin_of(&mesh.weld, &topology);
        let face_markers = (0..markers.len()).filter(|i| !head.contains(i)).count();
        let (static_vertices, rule) = if mesh.morph_targets.is_empty() && face_markers == 0 {
            (Vec::new(), StaticRule::NoMarkers)
        } else if mesh.morph_targets.is_empty() {
            let spacing = mean_spacing(markers);
            let distance = STATIC_SPACING_FACTOR * spacing;
            let mut still = far_from_markers(&mesh.positions, &skin, markers, head, distance);
            // The throat is judged in the face's own axes, under its mouth.
            let (frame, local) =
                face_openings(&topology, &mesh.welded_positions, &mesh.welded_triangles);
            let local_markers = frame.points(markers);
            let floor = mouth_and_eyes(&local).0.map_or_else(
                || local_markers.iter().map(|m| m[1]).sum::<f64>() / markers.len().max(1) as f64,
                |m| m.centre[1],
            );
            let throat = throat(
                &frame.points(&mesh.positions),
                &local_markers,
                floor,
                spacing,
            );
            still.retain(|&v| !throat[v as usize]);
            (still, StaticRule::FarFromMarkers { distance })
        } else {
            let threshold = crate::ground_truth::MOVING_FRACTION_OF_DIAGONAL * mesh.diagonal();
            let still = (0..mesh.positions.len())
                .filter(|&v| {
                    skin[v]
                        && mesh
                            .morph_targets
                            .iter()
                            .all(|t| norm(&t.deltas[v]) <= threshold)
                })
                .map(|v| v as u32)
                .collect();
            (still, StaticRule::MorphTargets)
        };
        let mut regions = Self::new(&mesh.positions, &mesh.triangles, static_vertices, rule)?;
        if !mesh.morph_targets.is_empty() {
            let rest = &mesh.positions;
            let mut longest: Vec<f64> = regions
                .edges
                .iter()
                .map(|&[a, b]| distance(&rest[a as usize], &rest[b as usize]))
                .collect();
            let mut turn = vec![false; regions.triangles.len()];
            for target in &mesh.morph_targets {
                let shaped = |v: u32| {
                    let (p, d) = (rest[v as usize], target.deltas[v as usize]);
                    [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
                };
                for (l, &[a, b]) in longest.iter_mut().zip(&regions.edges) {
                    *l = l.max(distance(&shaped(a), &shaped(b)));
                }
                let positions: Vec<[f64; 3]> = (0..rest.len() as u32).map(shaped).collect();
                for (turned, t) in turn.iter_mut().zip(&regions.triangles) {
                    *turned |= regions.turned(&positions, t);
                }
            }
            regions.longest = Some(longest);
            regions.shapes_turn = Some(turn);
        }
        Ok(regions)
    }

    /// The rest positions.
    pub fn rest(&self) -> &[[f64; 3]] {
        &self.rest
    }

    /// Per edge of [`Regions::edges`], the longest the mesh's own shapes make it: its rest
    /// length, or its length in a morph target at full weight if longer (`None`: the regions
    /// of a mesh without morph targets).
    pub fn shapes_longest(&self) -> Option<&[f64]> {
        self.longest.as_deref()
    }

    /// Whether triangle `t` faces against its rest normal at `positions`.
    pub fn turned(&self, positions: &[[f64; 3]], t: &[u32; 3]) -> bool {
        dot(&normal(positions, t), &normal(&self.rest, t)) < 0.0
    }

    /// Metrics of one frame: `positions` (one per vertex), `truth` if known (stretch and flips
    /// the truth has too then do not count; see the module docs). With
    /// `remove_rigid`, each of them is first brought back by its best rigid motion over the
    /// static region (for takes with head motion). Positions of the wrong length measure as
    /// if missing vertices stayed at rest.
    pub fn measure(
        &self,
        positions: &[[f64; 3]],
        truth: Option<&[[f64; 3]]>,
        remove_rigid: bool,
    ) -> FrameMetrics {
        let fix = |p: &[[f64; 3]]| -> Vec<[f64; 3]> {
            let mut p: Vec<[f64; 3]> = (0..self.vertex_count)
                .map(|v| p.get(v).copied().unwrap_or(self.rest[v]))
                .collect();
            if remove_rigid {
                let from: Vec<[f64; 3]> = self
                    .static_vertices
                    .iter()
                    .map(|&v| self.rest[v as usize])
                    .collect();
                let to: Vec<[f64; 3]> = self
                    .static_vertices
                    .iter()
                    .map(|&v| p[v as usize])
                    .collect();
                if let Ok(motion) = crate::stages::rigid::kabsch(&from, &to) {
                    p = p.iter().map(|q| motion.apply_inverse(q)).collect();
                }
            }
            p
        };
        let got = fix(positions);
        let truth = truth.map(fix);
        let mm = self.mm_per_unit;
        let static_drift_mm = self
            .static_vertices
            .iter()
            .map(|&v| distance(&got[v as usize], &self.rest[v as usize]))
            .fold(0.0, f64::max)
            * mm;
        let aperture = |pairs: &[&RimPairs]| -> Option<Aperture> {
            let pairs: Vec<[u32; 2]> = pairs.iter().flat_map(|p| p.iter().copied()).collect();
            if pairs.is_empty() {
                return None;
            }
            let gap =
                |p: &[[f64; 3]], [u, l]: [u32; 2]| distance(&p[u as usize], &p[l as usize]) * mm;
            let widest = |p: &[[f64; 3]]| pairs.iter().map(|&q| gap(p, q)).fold(0.0, f64::max);
            Some(Aperture {
                widest_mm: widest(&got),
                truth_widest_mm: truth.as_deref().map(widest),
                error_mm: truth.as_deref().map(|t| {
                    pairs
                        .iter()
                        .map(|&q| (gap(&got, q) - gap(t, q)).abs())
                        .fold(0.0, f64::max)
                }),
            })
        };
        let (mut max_stretch, mut edges_over_limit) = (0.0f64, 0);
        let shapes = self.longest.as_deref().filter(|_| truth.is_none());
        let beyond_shapes = shapes.map(|longest| {
            let edges = self.edges.iter().zip(longest);
            edges
                .filter(|(_, &l)| l > 0.0)
                .map(|(&[a, b], &l)| distance(&got[a as usize], &got[b as usize]) / l)
                .fold(0.0, f64::max)
        });
        for &[a, b] in &self.edges {
            let length = |p: &[[f64; 3]]| distance(&p[a as usize], &p[b as usize]);
            let allowed = truth.as_deref().map_or(0.0, length).max(length(&self.rest));
            if allowed > 0.0 {
                let ratio = length(&got) / allowed;
                max_stretch = max_stretch.max(ratio);
                edges_over_limit += usize::from(ratio > STRETCH_LIMIT);
            }
        }
        let turned = |p: &[[f64; 3]], t: &[u32; 3]| self.turned(p, t);
        let flipped_at: Vec<usize> = (0..self.triangles.len())
            .filter(|&i| {
                let t = &self.triangles[i];
                turned(&got, t) && !truth.as_deref().is_some_and(|p| turned(p, t))
            })
            .collect();
        let flipped = flipped_at.len();
        let flipped_beyond_shapes = (self.shapes_turn.as_deref())
            .filter(|_| truth.is_none())
            .map(|turn| flipped_at.iter().filter(|&&i| !turn[i]).count());
        FrameMetrics {
            static_drift_mm,
            static_measured: !self.static_vertices.is_empty(),
            lips: aperture(&[&self.lips]),
            eyelids: aperture(&self.eyes.iter().collect::<Vec<_>>()),
            max_stretch,
            beyond_shapes,
            edges_over_limit,
            flipped,
            flipped_beyond_shapes,
        }
    }

    /// Metrics of every frame of a take, and the worst over it.
    pub fn measure_take(
        &self,
        frames: &[Vec<[f64; 3]>],
        truth: Option<&[Vec<[f64; 3]>]>,
        remove_rigid: bool,
    ) -> (Vec<FrameMetrics>, TakeMetrics) {
        let per_frame: Vec<FrameMetrics> = frames
            .iter()
            .enumerate()
            .map(|(f, p)| {
                let t = truth.and_then(|t| t.get(f)).map(Vec::as_slice);
                self.measure(p, t, remove_rigid)
            })
            .collect();
        let take = TakeMetrics::of(&per_frame);
        (per_frame, take)
    }
}

/// Whether triangle `t` has a side to turn over at rest: its height is more than
/// [`DEGENERATE_HEIGHT_FRACTION`] of its longest edge. A zero-area triangle (three points on a
/// line, or a repeated vertex) has a normal made of rounding errors, which any motion can turn.
fn has_orientation(rest: &[[f64; 3]], t: &[u32; 3]) -> bool {
    let [a, b, c] = t.map(|v| rest[v as usize]);
    let longest = [distance(&a, &b), distance(&b, &c), distance(&c, &a)]
        .into_iter()
        .fold(0.0, f64::max);
    // Twice the area over the longest edge is the height onto it.
    longest > 0.0 && norm(&normal(rest, t)) > DEGENERATE_HEIGHT_FRACTION * longest * longest
}

/// The (unnormalised) normal of triangle `t` over `p`.
fn normal(p: &[[f64; 3]], t: &[u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| p[v as usize]);
    cross(&sub(&b, &a), &sub(&c, &a))
}

/// Mean distance from a marker to its nearest other marker (0 with fewer than two).
pub fn mean_spacing(markers: &[[f64; 3]]) -> f64 {
    if markers.len() < 2 {
        return 0.0;
    }
    let sum: f64 = crate::rbf::radial::nearest_distances(markers).iter().sum();
    sum / markers.len() as f64
}

/// Which of `positions` are the jaw's and the throat's: under the mouth's height `floor` plus
/// one `spacing`, no farther across from the face's middle (the markers' median x) than the
/// widest of the `markers` under the mouth's height plus one `spacing`, and within
/// [`THROAT_SPACING_FACTOR`] spacings of one of those markers (all in the face's own axes, y
/// up). A jaw open moves that skin however far it is from the face's markers, so the geometric
/// static rule leaves it out.
pub fn throat(positions: &[[f64; 3]], markers: &[[f64; 3]], floor: f64, spacing: f64) -> Vec<bool> {
    let jaw: Vec<&[f64; 3]> = markers.iter().filter(|m| m[1] < floor).collect();
    let middle = crate::surface::anchoring::middle_x(markers);
    let half_width = jaw
        .iter()
        .map(|m| (m[0] - middle).abs())
        .fold(0.0, f64::max)
        + spacing;
    let reach = THROAT_SPACING_FACTOR * spacing;
    positions
        .iter()
        .map(|p| {
            p[1] < floor + spacing
                && (p[0] - middle).abs() <= half_width
                && jaw.iter().any(|m| distance(m, p) < reach)
        })
        .collect()
}

/// Skin vertices farther than `distance` from every marker not in `head`.
pub fn far_from_markers(
    positions: &[[f64; 3]],
    skin: &[bool],
    markers: &[[f64; 3]],
    head: &[usize],
    distance_limit: f64,
) -> Vec<u32> {
    let face: Vec<&[f64; 3]> = markers
        .iter()
        .enumerate()
        .filter(|(i, _)| !head.contains(i))
        .map(|(_, p)| p)
        .collect();
    if face.is_empty() {
        return Vec::new();
    }
    (0..positions.len())
        .filter(|&v| {
            skin.get(v).copied().unwrap_or(false)
                && face
                    .iter()
                    .all(|m| distance(&positions[v], m) > distance_limit)
        })
        .map(|v| v as u32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 6 × 4 grid in the z = 0 plane (spacing 1 cm, y up) with a mouth-like slit: the cells
    /// of row 1, columns 1..4 are left out, so the opening's rim is rows 1 and 2, columns 1..4.
    /// The upper rim's ends are pulled 2 mm in, so the corners are the lower rim's ends. The
    /// outer rim is longer, so it is the cut, not an opening.
    fn slit() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let (w, h) = (7u32, 5u32);
        let p = (0..h)
            .flat_map(|y| (0..w).map(move |x| [0.01 * f64::from(x), 0.01 * f64::from(y), 0.0]))
            .collect::<Vec<_>>();
        let mut p = p;
        p[15][0] += 0.002;
        p[18][0] -= 0.002;
        let mut t = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                if y == 1 && (1..4).contains(&x) {
                    continue;
                }
                let i = y * w + x;
                t.push([i, i + 1, i + w + 1]);
                t.push([i, i + w + 1, i + w]);
            }
        }
        (p, t)
    }

    fn regions() -> Regions {
        let (p, t) = slit();
        // The top two rows are "static".
        Regions::new(&p, &t, (21..35).collect(), StaticRule::Given).unwrap()
    }

    #[test]
    fn the_slit_is_a_mouth_with_pairs_across_it() {
        let r = regions();
        assert!(r.eyes.is_empty());
        // Upper rim: row 2 (ids 15..=18); lower: row 1 inside the corners 8 and 11.
        let mut lips = r.lips.clone();
        lips.sort();
        assert_eq!(lips, vec![[15, 9], [16, 9], [17, 10], [18, 10]]);
    }

    #[test]
    fn rest_and_pure_translation_measure_nothing_but_drift() {
        let r = regions();
        let rest = r.rest().to_vec();
        let m = r.measure(&rest, Some(&rest), false);
        assert_eq!(m.static_drift_mm, 0.0);
        assert_eq!(m.lips.unwrap().error_mm, Some(0.0));
        // The slanted pairs at the ends are the widest: 8 mm across, 10 mm up.
        assert!((m.lips.unwrap().widest_mm - 164f64.sqrt()).abs() < 1e-9);
        assert!((m.max_stretch - 1.0).abs() < 1e-12);
        assert_eq!((m.edges_over_limit, m.flipped), (0, 0));
        let moved: Vec<[f64; 3]> = rest
            .iter()
            .map(|p| [p[0] + 0.003, p[1], p[2] - 0.004])
            .collect();
        let m = r.measure(&moved, None, false);
        assert!((m.static_drift_mm - 5.0).abs() < 1e-9);
        assert!((m.max_stretch - 1.0).abs() < 1e-12);
        assert_eq!((m.edges_over_limit, m.flipped), (0, 0));
        // Brought back by its rigid motion, a rotated and moved copy measures as rest.
        let (s, c) = (0.3f64.sin(), 0.3f64.cos());
        let turned: Vec<[f64; 3]> = rest
            .iter()
            .map(|p| [c * p[0] + s * p[2] + 0.01, p[1], -s * p[0] + c * p[2]])
            .collect();
        assert!(r.measure(&turned, None, false).static_drift_mm > 1.0);
        assert!(r.measure(&turned, None, true).static_drift_mm < 1e-9);
    }

    #[test]
    fn a_scaled_edge_gives_its_ratio() {
        let r = regions();
        let mut p = r.rest().to_vec();
        // Vertex 0 is a corner: its edges to 1, 7 and 8; pull it 2 cm further out in x.
        p[0][0] -= 0.02;
        let m = r.measure(&p, None, false);
        // 0–1 goes from 1 cm to 3 cm.
        assert!((m.max_stretch - 3.0).abs() < 1e-9, "{}", m.max_stretch);
        assert_eq!(m.edges_over_limit, 3);
        assert_eq!(m.flipped, 0);
    }

    #[test]
    fn a_take_says_what_went_wrong_and_where_and_nothing_when_nothing_did() {
        let r = regions();
        let rest = r.rest().to_vec();
        let mut pulled = rest.clone();
        pulled[0][0] -= 0.02;
        let (_, clean) = r.measure_take(&[rest.clone(), rest.clone()], None, false);
        let text = clean.to_string();
        assert!(
            text.ends_with("no edge over 2×, no flipped triangle"),
            "{text}"
        );
        let (_, torn) = r.measure_take(&[rest.clone(), pulled, rest], None, false);
        let text = torn.to_string();
        assert!(
            text.ends_with(
                "edges over 2×: up to 3 (frame 1) in 1 of 3 frames, no flipped triangle"
            ),
            "{text}"
        );
    }

    #[test]
    fn what_the_truth_does_too_is_not_a_fault() {
        let r = regions();
        let mut p = r.rest().to_vec();
        p[0][0] -= 0.02;
        // The truth stretches edge 0–1 3× as well: nothing is stretched beyond it.
        let m = r.measure(&p, Some(&p), false);
        assert!((m.max_stretch - 1.0).abs() < 1e-12);
        assert_eq!(m.edges_over_limit, 0);
        // Half the true stretch is no stretch; twice the rest length where the truth stays
        // at rest is.
        let mut half = r.rest().to_vec();
        half[0][0] -= 0.01;
        assert!((r.measure(&half, Some(&p), false).max_stretch - 1.0).abs() < 1e-12);
        assert!((r.measure(&p, Some(r.rest()), false).max_stretch - 3.0).abs() < 1e-9);
        // A flip the truth has too does not count; one it lacks does.
        let mut q = r.rest().to_vec();
        q.swap(0, 1);
        assert_eq!(r.measure(&q, Some(&q), false).flipped, 0);
        assert!(r.measure(&q, Some(r.rest()), false).flipped > 0);
        assert_eq!(r.measure(r.rest(), Some(&q), false).flipped, 0);
    }

    #[test]
    fn a_fold_the_meshs_own_shapes_make_is_told_apart() {
        let (p, t) = slit();
        let mut mesh = FaceMesh::from_triangles("slit", p, t);
        // A target that pushes vertex 0 past its neighbours turns triangle 0–1–8 over.
        let mut deltas = vec![[0.0; 3]; mesh.positions.len()];
        deltas[0] = [0.02, 0.005, 0.0];
        mesh.morph_targets.push(crate::model::MorphTarget {
            name: "fold".into(),
            deltas: deltas.clone(),
        });
        let shaped = Regions::for_mesh(&mesh, &[], &[]).unwrap();
        let mut folded = mesh.positions.clone();
        folded[0] = [0.02, 0.005, 0.0];
        let m = shaped.measure(&folded, None, false);
        assert_eq!((m.flipped, m.flipped_beyond_shapes), (1, Some(0)), "{m:?}");
        // Vertex 34 pushed in turns its two triangles over, which no target does.
        let mut both = folded.clone();
        both[34] = [0.04, 0.025, 0.0];
        let m = shaped.measure(&both, None, false);
        assert_eq!((m.flipped, m.flipped_beyond_shapes), (3, Some(2)), "{m:?}");
        let (_, take) = shaped.measure_take(&[folded.clone(), both.clone()], None, false);
        assert_eq!(take.flipped_beyond_shapes, Some((2, 1)));
        assert!(
            take.to_string().contains(
                "flipped up to 3 (frame 1; up to 2 that its own shapes do not turn over, frame 1)"
            ),
            "{take}"
        );
        let (_, take) = shaped.measure_take(std::slice::from_ref(&folded), None, false);
        assert!(
            take.to_string()
                .contains("flipped up to 1 (frame 0; each one its own shapes turn over too)"),
            "{take}"
        );
        // Without targets, or with a truth, nothing is told apart.
        mesh.morph_targets.clear();
        let plain = Regions::for_mesh(&mesh, &[], &[]).unwrap();
        assert_eq!(
            plain.measure(&folded, None, false).flipped_beyond_shapes,
            None
        );
        let truth = shaped.rest().to_vec();
        assert_eq!(
            shaped
                .measure(&folded, Some(&truth), false)
                .flipped_beyond_shapes,
            None
        );
    }

    #[test]
    fn what_the_meshs_own_shapes_do_is_not_a_fault() {
        let (p, t) = slit();
        let mut mesh = FaceMesh::from_triangles("slit", p, t);
        let mut pulled = mesh.positions.clone();
        pulled[0][0] -= 0.02;
        let plain = Regions::for_mesh(&mesh, &[], &[]).unwrap();
        assert!((plain.measure(&pulled, None, false).max_stretch - 3.0).abs() < 1e-9);
        // A target that pulls vertex 0 out 1 cm lets edge 0–1 be 2 cm long (3 cm is 1.5×) and
        // edge 0–7 √2 cm (√5 cm is the worst, 1.58×).
        let mut deltas = vec![[0.0; 3]; mesh.positions.len()];
        deltas[0][0] = -0.01;
        mesh.morph_targets.push(crate::model::MorphTarget {
            name: "pull".into(),
            deltas,
        });
        let shaped = Regions::for_mesh(&mesh, &[], &[]).unwrap();
        let m = shaped.measure(&pulled, None, false);
        let worst = (5.0f64 / 2.0).sqrt();
        let beyond = m.beyond_shapes.expect("a mesh with targets");
        assert!((beyond - worst).abs() < 1e-9, "{m:?}");
        // The stretch the bars count is still from rest.
        assert!((m.max_stretch - 3.0).abs() < 1e-9, "{}", m.max_stretch);
        assert_eq!(m.edges_over_limit, 3);
        assert_eq!(plain.measure(&pulled, None, false).beyond_shapes, None);
        let (_, take) = shaped.measure_take(&[mesh.positions.clone(), pulled.clone()], None, false);
        assert_eq!(take.beyond_shapes, Some((beyond, 1)));
        assert!(
            take.to_string()
                .contains("stretch 3.00× (frame 1; 1.58× its own shapes' longest, frame 1)"),
            "{take}"
        );
        // With a truth, the truth is the measure.
        let truth = shaped.rest().to_vec();
        let m = shaped.measure(&pulled, Some(&truth), false);
        assert_eq!(m.beyond_shapes, None);
    }

    #[test]
    fn a_vertex_pushed_through_flips_its_triangles() {
        let r = regions();
        let mut p = r.rest().to_vec();
        // Vertex 1 (bottom row) pushed up past row 1: its triangles turn over.
        p[1][1] += 0.015;
        let m = r.measure(&p, None, false);
        assert!(m.flipped >= 1, "{m}");
        // A swapped pair of vertices flips every triangle that uses exactly one of them.
        let mut q = r.rest().to_vec();
        q.swap(0, 1);
        assert!(r.measure(&q, None, false).flipped > 0);
    }

    #[test]
    fn a_zero_area_triangle_has_no_side_to_flip() {
        // A triangle over three points of the bottom row, the middle one a rounding error
        // below the line: its rest normal is made of that error.
        let (mut p, mut t) = slit();
        p[1][1] -= 1e-12;
        t.push([0, 1, 2]);
        let r = Regions::new(&p, &t, (21..35).collect(), StaticRule::Given).unwrap();
        assert!(r.triangles.iter().all(|x| x != &[0, 1, 2]));
        // Raised a millimetre, the middle vertex turns that normal over but none of the real
        // triangles around it.
        let mut q = p.clone();
        q[1][1] += 0.001;
        assert_eq!(r.measure(&q, None, false).flipped, 0);
        assert!(dot(&normal(&q, &[0, 1, 2]), &normal(&p, &[0, 1, 2])) < 0.0);
    }

    #[test]
    fn lips_moved_apart_change_the_aperture() {
        let r = regions();
        let rest = r.rest().to_vec();
        let mut open = rest.clone();
        for p in &mut open[14..21] {
            p[1] += 0.004;
        }
        // Against a truth at rest: off by the 4 mm the lips parted.
        let m = r.measure(&open, Some(&rest), false);
        let lips = m.lips.unwrap();
        assert!((lips.error_mm.unwrap() - 4.0).abs() < 1e-9);
        assert!((lips.widest_mm - 260f64.sqrt()).abs() < 1e-9);
        assert!((lips.truth_widest_mm.unwrap() - 164f64.sqrt()).abs() < 1e-9);
        // Without a truth the figure is the aperture.
        let figure = r.measure(&open, None, false).lips.unwrap().figure_mm();
        assert!((figure - 260f64.sqrt()).abs() < 1e-9);
        let take = TakeMetrics::of(&[r.measure(&rest, Some(&rest), false), m]);
        assert_eq!(take.lips_mm.map(|l| l.1), Some(1));
        assert_eq!(take.eyelids_mm, None);
    }

    #[test]
    fn pieces_other_than_the_skin_are_not_measured() {
        let (mut p, mut t) = slit();
        let n = p.len() as u32;
        p.extend([[0.1, 0.0, 0.0], [0.11, 0.0, 0.0], [0.1, 0.01, 0.0]]);
        t.push([n, n + 1, n + 2]);
        let r = Regions::new(&p, &t, vec![], StaticRule::Given).unwrap();
        let mut q = p.clone();
        // The loose triangle stretched 5× and turned over: not the skin, not counted.
        q[n as usize + 1][0] = 0.05;
        let m = r.measure(&q, None, false);
        assert!((m.max_stretch - 1.0).abs() < 1e-12);
        assert_eq!((m.edges_over_limit, m.flipped), (0, 0));
    }

    #[test]
    fn bad_input_is_an_error() {
        let (p, mut t) = slit();
        assert!(matches!(
            Regions::new(&p, &t, vec![99], StaticRule::Given),
            Err(MetricsError::BadStaticVertex { vertex: 99, .. })
        ));
        t.push([0, 1, 1000]);
        assert!(matches!(
            Regions::new(&p, &t, vec![], StaticRule::Given),
            Err(MetricsError::BadTriangle { vertex: 1000, .. })
        ));
    }

    #[test]
    fn the_geometric_static_rule_keeps_far_skin() {
        let p = [
            [0.0, 0.0, 0.0],
            [0.05, 0.0, 0.0],
            [0.2, 0.0, 0.0],
            [0.01, 0.0, 0.0],
        ];
        let markers = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.2, 0.0, 0.0]];
        assert!((mean_spacing(&markers) - (0.01 + 0.01 + 0.19) / 3.0).abs() < 1e-12);
        // The marker at 0.2 is a head marker: it does not stop vertex 2 being static.
        let skin = [true, true, true, false];
        assert_eq!(
            far_from_markers(&p, &skin, &markers, &[2], 0.03),
            vec![1, 2]
        );
    }
}
