//! Placing the actor's markers on the character from a few landmarks (paper 000 §6): the
//! landmarks are markers whose place on the character is known (given as vertices); an RBF map
//! (inverse multiquadric plus affine, [`RetargetMap`]) warps the actor's neutral markers through
//! them into the character's space, and each warped marker is projected onto the closest point
//! of the character's skin.
//!
//! [`landmarks`] finds seven landmarks from the mesh's own shape: the four eye corners and two
//! mouth corners (x-extremes of the eye and lip openings) and the nose tip (the skin's most
//! forward vertex); [`place`] does the whole placement, in the face's own axes. The lip centre markers are not
//! landmarks: FaceCap's lips are closed (the opening's top and bottom are 4 mm apart) while the
//! capture's sit on the outer lips, 30 mm apart.

use crate::mesh::{closest_point, distance};
use crate::model::FaceMesh;
use crate::model::{LayoutMarker, MarkerAnchor, MarkerLayout};
use crate::stages::retarget::RetargetMap;

/// Placement failed.
#[derive(Debug, thiserror::Error)]
pub enum PlacementError {
    /// A landmark names a marker the actor does not have.
    #[error("landmark {0:?} is not one of the actor's markers")]
    UnknownLandmark(String),
    /// A landmark's anchor is not a vertex of the mesh.
    #[error("landmark {name:?} anchors vertex {vertex}, but the mesh has {count} vertices")]
    BadVertex {
        /// The landmark.
        name: String,
        /// Its vertex.
        vertex: u32,
        /// Vertices in the mesh.
        count: usize,
    },
    /// The landmarks cannot define a warp.
    #[error("the landmarks cannot define a warp: {0}")]
    Warp(#[from] crate::rbf::SolveError),
    /// The mesh lacks a feature the landmarks need.
    #[error("{0}")]
    Mesh(String),
    /// The landmarks cannot be found on the mesh (it has no mouth and eye openings) and not
    /// all of them are pinned.
    #[error("{why}; to place on a face without them, pin every landmark (not pinned: {unpinned})")]
    LandmarksUnfound {
        /// Why they cannot be found.
        why: String,
        /// The landmarks not pinned, comma separated.
        unpinned: String,
    },
    /// An alias ([`place_aliased`]) names no marker of the actor, no name of the thesis'
    /// layout, or a name another marker already has.
    #[error("alias {actor}={thesis}: {problem}")]
    BadAlias {
        /// The actor's marker name.
        actor: String,
        /// The thesis' name it was given.
        thesis: String,
        /// What is wrong with it.
        problem: String,
    },
}

/// The actor's neutral markers placed on `mesh`: landmarks at their vertices, every other marker
/// warped through the landmarks and projected onto the largest connected piece (the skin).
/// Returns a layout with point anchors in the actor's marker order, less the markers that warp
/// further than [`OFF_FACE`] × the mesh's diagonal from the skin: not the face's (a shoulder, a
/// camera rig), which would otherwise be pulled onto it and drag it.
pub fn place_from_landmarks(
    actor_names: &[String],
    actor_neutral: &[[f64; 3]],
    landmarks: &MarkerLayout,
    mesh: &FaceMesh,
) -> Result<MarkerLayout, PlacementError> {
    let mut from = Vec::new();
    let mut to = Vec::new();
    for lm in &landmarks.markers {
        let i = actor_names
            .iter()
            .position(|n| *n == lm.name)
            .ok_or_else(|| PlacementError::UnknownLandmark(lm.name.clone()))?;
        let vertex = match lm.anchor {
            MarkerAnchor::Vertex(v) => v,
            MarkerAnchor::Point(p) => {
                from.push(actor_neutral[i]);
                to.push(p);
                continue;
            }
        };
        let p = mesh
            .positions
            .get(vertex as usize)
            .ok_or(PlacementError::BadVertex {
                name: lm.name.clone(),
                vertex,
                count: mesh.positions.len(),
            })?;
        from.push(actor_neutral[i]);
        to.push(*p);
    }
    let warp = RetargetMap::new(&from, &to)?;
    let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    let skin_triangles: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|t| topo.components.vertex_component[mesh.weld[t[0] as usize] as usize] == 0)
        .copied()
        .collect();
    let off_face = OFF_FACE * mesh.diagonal();
    let mut markers = Vec::with_capacity(actor_names.len());
    for (name, p) in actor_names.iter().zip(actor_neutral) {
        let anchor = match landmarks.markers.iter().find(|l| l.name == *name) {
            Some(l) => l.anchor,
            None => {
                let warped = warp.map(p);
                let on_skin = closest_point(&mesh.positions, &skin_triangles, warped)
                    .ok_or_else(|| PlacementError::Mesh("the mesh has no skin triangles".into()))?;
                if on_skin.distance > off_face {
                    continue;
                }
                MarkerAnchor::Point(on_skin.point)
            }
        };
        markers.push(LayoutMarker {
            name: name.clone(),
            anchor,
            stiffness: 1.0,
        });
    }
    Ok(MarkerLayout {
        source: landmarks.source.clone(),
        markers,
        groups: Vec::new(),
        triangles: None,
    })
}

/// A marker warped further than this fraction of the mesh's bounding-box diagonal from its skin
/// is not the face's and is left out ([`place_from_landmarks`]). The face's own markers warp at
/// most 0.062 of it off FaceCap's skin (`Chin_L2`, JawMoCap's layout), 0.046 off ICT-FaceKit's
/// and 0.106 off MediaPipe's mask of a face (`ForeHead_M`, past its top edge); a shoulder is
/// half a head's diagonal away.
pub const OFF_FACE: f64 = 0.2;

/// Which opening a feature marker sits beside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// The mouth.
    Mouth,
    /// The subject's left eye (+X).
    LeftEye,
    /// The subject's right eye (−X).
    RightEye,
}

/// Markers of the thesis' MPEG-4 layout (Table 4.1) that sit on a lip or an eyelid: (name,
/// opening, upper side, place along the opening as a fraction of its half width from its centre
/// towards the subject's left). The actor wore them there; a warp from a few landmarks cannot put
/// them there on another face, because lips and lids differ in shape more than anything else.
pub const FEATURE_MARKERS: [(&str, Feature, bool, f64); 10] = [
    ("Mouth_Up", Feature::Mouth, true, 0.0),
    ("Mouth_UpL1", Feature::Mouth, true, 0.5),
    ("Mouth_UpR1", Feature::Mouth, true, -0.5),
    ("Mouth_Down", Feature::Mouth, false, 0.0),
    ("Mouth_DownL", Feature::Mouth, false, 0.5),
    ("Mouth_DownR", Feature::Mouth, false, -0.5),
    ("Leye_Up", Feature::LeftEye, true, 0.0),
    ("Leye_Down", Feature::LeftEye, false, 0.0),
    ("Reye_Up", Feature::RightEye, true, 0.0),
    ("Reye_Down", Feature::RightEye, false, 0.0),
];

/// How far along the skin from its opening a feature marker sits, as a fraction of the
/// opening's width: on the lip's or lid's visible surface, clear of the rim.
pub const FEATURE_OFFSET: f64 = 0.1;

/// A feature marker goes on the skin vertex nearest its place: the cost of a vertex is its
/// distance across the face from the place along the opening plus this many times its distance
/// from [`FEATURE_OFFSET`] off the rim, for an eyelid marker. A lid is a few vertex rows tall,
/// so the row matters more than the column: at 0.3 (the lips' weight) the wider face's lid
/// markers went on the second row, 4.0–4.6 mm off the rim instead of 2.6, and its blink closed
/// 1.5 mm short; at 1 (and 2) 0.8 mm, FaceCap and the other faces on the same vertices
/// (`--test other_faces`).
pub const LID_OFF_RIM_COST: f64 = 1.0;

/// [`LID_OFF_RIM_COST`] for a lip marker. At 1 FaceCap's lower lip markers move to a row
/// farther from the rim and the truth stretches an edge 2.10× (lips 7.2 mm against 6.8).
pub const LIP_OFF_RIM_COST: f64 = 0.3;

/// The mouth and eye openings of a face mesh's skin ([`crate::openings`]: its boundary loops
/// less the cut, the eyes the two most alike), as loops of welded vertices: mouth, left eye
/// (larger x), right eye.
pub fn face_openings(mesh: &FaceMesh) -> Result<[Vec<u32>; 3], PlacementError> {
    let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    let openings =
        crate::openings::skin_openings(&topo, &mesh.welded_positions, &mesh.welded_triangles);
    let Some((lips, [right, left])) = crate::openings::mouth_and_eyes(&openings) else {
        return Err(PlacementError::Mesh(format!(
            "{}: the skin has {} openings; placing lip and eyelid markers needs 3 (lips, two eyes)",
            mesh.source.display(),
            openings.len()
        )));
    };
    Ok([
        lips.vertices.clone(),
        left.vertices.clone(),
        right.vertices.clone(),
    ])
}

/// Whether `mesh`'s skin has the mouth and eye openings [`place`] finds the landmarks from and
/// puts the lip and eyelid markers beside.
pub fn has_openings(mesh: &FaceMesh) -> bool {
    face_openings(&crate::frame::FaceFrame::of(mesh).mesh(mesh)).is_ok()
}

/// Put every marker of [`FEATURE_MARKERS`] that `layout` has on its lip or eyelid: on the skin
/// [`FEATURE_OFFSET`] × the opening's width from the opening's upper or lower rim, at its
/// fraction of the opening's half width. Other markers are left where they are.
pub fn snap_to_features(layout: &mut MarkerLayout, mesh: &FaceMesh) -> Result<(), PlacementError> {
    if !has_feature_markers(layout) {
        return Ok(());
    }
    let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    let rims = face_openings(mesh)?.map(|rim| {
        let (upper, lower) = rim_sides(&rim, &mesh.welded_positions, &topo.neighbours);
        Beside::Opening { rim, upper, lower }
    });
    let graph = crate::geodesic::dijkstra::Graph::new(&topo);
    snap_beside(layout, mesh, &topo, &graph, rims)
}

/// [`snap_to_features`] for a face whose lips and lids are closed (no openings): each lip or lid
/// marker goes beside the line its lips or lids meet along, the shortest path on the skin
/// between its opening's corners (`corners`: glTF vertices of the mouth's, the left eye's and
/// the right eye's, each pair in any order), above it for an upper marker, below it for a lower,
/// "above" along the mesh's +Y (a face without openings has no axes of its own for
/// [`crate::frame::FaceFrame`] to find, so it must stand upright in its file).
pub fn snap_to_seams(
    layout: &mut MarkerLayout,
    mesh: &FaceMesh,
    corners: [[u32; 2]; 3],
) -> Result<(), PlacementError> {
    if !has_feature_markers(layout) {
        return Ok(());
    }
    let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    let graph = crate::geodesic::dijkstra::Graph::new(&topo);
    let welded = |v: u32| {
        mesh.weld
            .get(v as usize)
            .copied()
            .ok_or(PlacementError::BadVertex {
                name: "a corner".into(),
                vertex: v,
                count: mesh.positions.len(),
            })
    };
    let mut seams = Vec::with_capacity(3);
    for [a, b] in corners {
        let seam = seam_between(
            &topo,
            &graph,
            &mesh.welded_positions,
            welded(a)?,
            welded(b)?,
        )
        .ok_or_else(|| {
            PlacementError::Mesh(format!(
                "{}: no path over the skin between the corners at vertices {a} and {b}",
                mesh.source.display()
            ))
        })?;
        seams.push(Beside::Seam(seam));
    }
    let rims: [Beside; 3] = seams
        .try_into()
        .map_err(|_| PlacementError::Mesh("three seams expected".into()))?;
    snap_beside(layout, mesh, &topo, &graph, rims)
}

/// Whether `layout` has a marker of [`FEATURE_MARKERS`].
fn has_feature_markers(layout: &MarkerLayout) -> bool {
    layout
        .markers
        .iter()
        .any(|m| FEATURE_MARKERS.iter().any(|f| f.0 == m.name))
}

/// What a lip or lid marker goes beside: an opening (its rim, and the rim's upper and lower
/// chains) or, on a face whose lips or lids are closed, the seam they meet along.
enum Beside {
    /// An opening of the skin.
    Opening {
        /// Its rim, a loop of welded vertices.
        rim: Vec<u32>,
        /// The rim's upper chain ([`rim_sides`]).
        upper: Vec<u32>,
        /// Its lower chain.
        lower: Vec<u32>,
    },
    /// A closed opening's seam, welded vertices from corner to corner ([`seam_between`]).
    Seam(Vec<u32>),
}

/// The shortest edge path over the skin from welded vertex `a` to `b`, both included: where a
/// closed mouth's lips or a closed eye's lids meet, between their corners. `None` if `b`
/// cannot be reached from `a`.
fn seam_between(
    topo: &crate::mesh::Topology,
    graph: &crate::geodesic::dijkstra::Graph,
    p: &[[f64; 3]],
    a: u32,
    b: u32,
) -> Option<Vec<u32>> {
    let d = crate::geodesic::dijkstra::distances(graph, &[(a, 0.0)]);
    let (mut path, mut v) = (vec![b], b as usize);
    // Back from `b`, each step to the neighbour its shortest path came through; the distance
    // falls at every step, so this ends within a step per vertex.
    for _ in 0..p.len() {
        if v == a as usize {
            return Some(path);
        }
        let through = |u: &u32| d[*u as usize] + distance(&p[*u as usize], &p[v]);
        match topo.neighbours[v]
            .iter()
            .min_by(|x, y| through(x).total_cmp(&through(y)))
        {
            Some(&u) if d[u as usize] < d[v] => {
                path.push(u);
                v = u as usize;
            }
            _ => break,
        }
    }
    None
}

/// One side of a rim or seam: per welded vertex, its distance from the rim and whether it lies
/// on that side.
type Side = (Vec<f64>, Vec<bool>);

/// Snap the feature markers of `layout` beside `rims` (mouth, left eye, right eye).
fn snap_beside(
    layout: &mut MarkerLayout,
    mesh: &FaceMesh,
    topo: &crate::mesh::Topology,
    graph: &crate::geodesic::dijkstra::Graph,
    rims: [Beside; 3],
) -> Result<(), PlacementError> {
    let p = &mesh.welded_positions;
    let original = mesh.welded_to_original();
    let skin = &topo.components.vertex_component;
    let from = |chain: &[u32]| {
        let seeds: Vec<(u32, f64)> = chain.iter().map(|&v| (v, 0.0)).collect();
        crate::geodesic::dijkstra::distances(graph, &seeds)
    };
    for (opening, beside) in [Feature::Mouth, Feature::LeftEye, Feature::RightEye]
        .into_iter()
        .zip(&rims)
    {
        // Per side, each vertex's distance from the rim and whether it is on that side.
        let (outline, sides): (&[u32], [Side; 2]) = match beside {
            Beside::Opening { rim, upper, lower } => {
                let (d_up, d_low) = (from(upper), from(lower));
                let on_upper: Vec<bool> = d_up.iter().zip(&d_low).map(|(u, l)| u < l).collect();
                let on_lower = d_up.iter().zip(&d_low).map(|(u, l)| l < u).collect();
                (rim, [(d_up, on_upper), (d_low, on_lower)])
            }
            Beside::Seam(seam) => {
                let d = from(seam);
                let line = seam_line(seam, p);
                let above: Vec<bool> = p.iter().map(|q| q[1] > height_at(&line, q[0])).collect();
                let below = above.iter().map(|a| !a).collect();
                (seam, [(d.clone(), above), (d, below)])
            }
        };
        let (lo, hi) = outline
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(p[v as usize][0]), hi.max(p[v as usize][0]))
            });
        let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let offset = FEATURE_OFFSET * 2.0 * half;
        for &(name, feature, is_upper, along) in &FEATURE_MARKERS {
            if feature != opening {
                continue;
            }
            let Some(marker) = layout.markers.iter_mut().find(|m| m.name == name) else {
                continue;
            };
            let (near, on_side) = &sides[usize::from(!is_upper)];
            let x = centre + along * half;
            // The skin vertex on this side, about `offset` from the rim, closest to the place
            // along the opening. Beside a seam, whose skin need not have a row of vertices that
            // near (a closed face is often coarse there), up to twice as far.
            let band = match beside {
                Beside::Opening { .. } => 0.5 * offset,
                Beside::Seam(_) => offset,
            };
            let best = (0..p.len())
                .filter(|&v| skin[v] == 0 && on_side[v])
                .filter(|&v| (near[v] - offset).abs() <= band)
                .min_by(|&a, &b| {
                    let off_rim = match feature {
                        Feature::Mouth => LIP_OFF_RIM_COST,
                        Feature::LeftEye | Feature::RightEye => LID_OFF_RIM_COST,
                    };
                    let cost = |v: usize| (p[v][0] - x).abs() + off_rim * (near[v] - offset).abs();
                    cost(a).total_cmp(&cost(b))
                })
                .ok_or_else(|| {
                    PlacementError::Mesh(format!(
                        "{}: no skin {} from the {:?} opening's {} rim for marker {name}",
                        mesh.source.display(),
                        offset,
                        opening,
                        if is_upper { "upper" } else { "lower" }
                    ))
                })?;
            marker.anchor = MarkerAnchor::Vertex(original[best]);
        }
    }
    Ok(())
}

/// `seam`'s vertices (welded) as (x, height) points in order of x.
fn seam_line(seam: &[u32], p: &[[f64; 3]]) -> Vec<[f64; 2]> {
    let mut points: Vec<[f64; 2]> = seam
        .iter()
        .map(|&v| [p[v as usize][0], p[v as usize][1]])
        .collect();
    points.sort_by(|a, b| a[0].total_cmp(&b[0]));
    points
}

/// The height of the polyline `line` ([`seam_line`]) at `x`, its end's height past either end.
fn height_at(line: &[[f64; 2]], x: f64) -> f64 {
    let (Some(first), Some(last)) = (line.first(), line.last()) else {
        return 0.0;
    };
    if x <= first[0] {
        return first[1];
    }
    line.windows(2).find(|w| x <= w[1][0]).map_or(last[1], |w| {
        let span = w[1][0] - w[0][0];
        let t = if span > 0.0 {
            (x - w[0][0]) / span
        } else {
            0.0
        };
        w[0][1] + t * (w[1][1] - w[0][1])
    })
}

/// An opening's rim split at its two x-extremes (the mouth's corners, the eye's) into the upper
/// and the lower chain, corners excluded. The upper chain is the one whose skin neighbours off
/// the rim lie higher: a closed mouth's two rims can be at the same height.
fn rim_sides(rim: &[u32], p: &[[f64; 3]], neighbours: &[Vec<u32>]) -> (Vec<u32>, Vec<u32>) {
    let (a, b) = {
        let (i, j) = crate::mesh::x_extremes(rim, p);
        (i.min(j), i.max(j))
    };
    let first: Vec<u32> = rim[a + 1..b].to_vec();
    let second: Vec<u32> = rim[b + 1..].iter().chain(&rim[..a]).copied().collect();
    let off_height = |chain: &[u32]| {
        let mut sum = 0.0;
        let mut count = 0usize;
        for &v in chain {
            for &u in &neighbours[v as usize] {
                if !rim.contains(&u) {
                    sum += p[u as usize][1];
                    count += 1;
                }
            }
        }
        sum / count.max(1) as f64
    };
    if off_height(&first) >= off_height(&second) {
        (first, second)
    } else {
        (second, first)
    }
}

/// The seven landmarks' names in the thesis' marker layout (Table 4.1): the corners of the
/// mouth (subject's left, right), of the left eye (outer, inner) and of the right eye (outer,
/// inner), and the nose tip.
pub const LANDMARK_NAMES: [&str; 7] = [
    "Mouth_Lend",
    "Mouth_Rend",
    "Leye_Outside",
    "Leye_Inside",
    "Reye_Outside",
    "Reye_Inside",
    "NoseHead",
];

/// Whether `name` is one of the thesis' names [`place`] reads a role from: a landmark
/// ([`LANDMARK_NAMES`]) or a lip or eyelid marker ([`FEATURE_MARKERS`]).
pub fn has_role(name: &str) -> bool {
    LANDMARK_NAMES.contains(&name) || FEATURE_MARKERS.iter().any(|f| f.0 == name)
}

/// The seven landmarks of the thesis' marker layout, found from `mesh`'s own shape: the corners
/// of the mouth and of each eye (the x-extremes of their openings, [`face_openings`]) and the
/// nose tip (the skin's most forward vertex), read in the file's axes (+X the subject's left,
/// +Y up, +Z forward; [`place`] reads any pose in the face's own). Vertices are glTF vertex
/// indices.
pub fn landmarks(mesh: &FaceMesh) -> Result<MarkerLayout, PlacementError> {
    let [lips, left_eye, right_eye] = face_openings(mesh)?;
    let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    let p = &mesh.welded_positions;
    let original = mesh.welded_to_original();
    let extreme = |vs: &[u32], key: &dyn Fn(&[f64; 3]) -> f64, max: bool| -> u32 {
        let cmp = |a: &&u32, b: &&u32| key(&p[**a as usize]).total_cmp(&key(&p[**b as usize]));
        let v = if max {
            vs.iter().max_by(cmp)
        } else {
            vs.iter().min_by(cmp)
        };
        v.copied().unwrap_or(0)
    };
    let x = |q: &[f64; 3]| q[0];
    let skin = topo.components.vertices_of(0);
    // The subject's left is +X (the capture's convention and FaceCap's), in the order of
    // LANDMARK_NAMES.
    let marks: [u32; 7] = [
        extreme(&lips, &x, true),
        extreme(&lips, &x, false),
        extreme(&left_eye, &x, true),
        extreme(&left_eye, &x, false),
        extreme(&right_eye, &x, false),
        extreme(&right_eye, &x, true),
        extreme(&skin, &|q| q[2], true),
    ];
    Ok(MarkerLayout {
        source: mesh.source.clone(),
        markers: LANDMARK_NAMES
            .iter()
            .zip(marks)
            .map(|(&name, welded)| LayoutMarker {
                name: name.to_string(),
                anchor: MarkerAnchor::Vertex(original[welded as usize]),
                stiffness: 1.0,
            })
            .collect(),
        groups: Vec::new(),
        triangles: None,
    })
}

/// The actor's markers (`actor_names`, at their `actor_neutral` positions) placed on `mesh`, a
/// face in any pose in its file: the [`landmarks`] at their vertices, the other markers warped
/// through them onto the skin ([`place_from_landmarks`]), then the lip and eyelid markers put on
/// the lips and lids ([`snap_to_features`]), all read in the face's own axes
/// ([`crate::frame::FaceFrame`]). The actor's markers must include the seven landmarks' names.
/// `pins` (marker name, glTF vertex) put markers where the user knows they belong: each is a
/// landmark of the warp too (replacing a found one of the same name) and is not snapped. A face
/// whose skin has no mouth and eye openings ([`has_openings`]: a sculpt or a scan with its lips
/// and lids closed) is placed only if every landmark is pinned, and its lip and eyelid markers
/// go beside the seams between the pinned corners ([`snap_to_seams`]).
pub fn place(
    mesh: &FaceMesh,
    actor_names: &[String],
    actor_neutral: &[[f64; 3]],
    pins: &[(String, u32)],
) -> Result<MarkerLayout, PlacementError> {
    let frame = crate::frame::FaceFrame::of(mesh);
    let local = frame.mesh(mesh);
    let openings = face_openings(&local);
    let mut marks = match landmarks(&local) {
        Ok(marks) => marks,
        // A face without openings (a sculpt or a scan, its lips and lids closed) is placed
        // from landmarks the user pinned, every one of them.
        Err(e) => {
            let unpinned: Vec<&str> = LANDMARK_NAMES
                .into_iter()
                .filter(|name| !pins.iter().any(|(pinned, _)| pinned == name))
                .collect();
            if !unpinned.is_empty() {
                return Err(PlacementError::LandmarksUnfound {
                    why: e.to_string(),
                    unpinned: unpinned.join(", "),
                });
            }
            MarkerLayout {
                source: mesh.source.clone(),
                markers: Vec::new(),
                groups: Vec::new(),
                triangles: None,
            }
        }
    };
    for (name, vertex) in pins {
        marks.markers.retain(|m| m.name != *name);
        marks.markers.push(LayoutMarker {
            name: name.clone(),
            anchor: MarkerAnchor::Vertex(*vertex),
            stiffness: 1.0,
        });
    }
    let mut layout = place_from_landmarks(actor_names, actor_neutral, &marks, &local)?;
    if openings.is_ok() {
        snap_to_features(&mut layout, &local)?;
    } else {
        // Every landmark is pinned (above): the corners of the closed mouth and eyes.
        let pinned = |name: &str| pins.iter().find(|(n, _)| n == name).map_or(0, |(_, v)| *v);
        let corners = [
            ["Mouth_Lend", "Mouth_Rend"],
            ["Leye_Outside", "Leye_Inside"],
            ["Reye_Outside", "Reye_Inside"],
        ]
        .map(|pair| pair.map(pinned));
        snap_to_seams(&mut layout, &local, corners)?;
    }
    for m in &mut layout.markers {
        if let Some((_, vertex)) = pins.iter().find(|(name, _)| *name == m.name) {
            m.anchor = MarkerAnchor::Vertex(*vertex);
        } else if let MarkerAnchor::Point(q) = m.anchor {
            m.anchor = MarkerAnchor::Point(frame.file(&q));
        }
    }
    layout.source = mesh.source.clone();
    Ok(layout)
}

/// [`place`] for a capture whose markers go by other names than the thesis': each alias
/// `(actor, thesis)` says that the actor's marker `actor` is the thesis' `thesis` (a landmark or
/// a lip or eyelid marker, [`has_role`]), so it is placed as that one is. The layout keeps the
/// actor's names (`bake` and `play` match the capture's markers by them); `pins` name the
/// actor's markers too.
pub fn place_aliased(
    mesh: &FaceMesh,
    actor_names: &[String],
    actor_neutral: &[[f64; 3]],
    pins: &[(String, u32)],
    aliases: &[(String, String)],
) -> Result<MarkerLayout, PlacementError> {
    let bad = |actor: &str, thesis: &str, problem: String| PlacementError::BadAlias {
        actor: actor.to_string(),
        thesis: thesis.to_string(),
        problem,
    };
    let mut names = actor_names.to_vec();
    for (actor, thesis) in aliases {
        if !has_role(thesis) {
            return Err(bad(
                actor,
                thesis,
                format!(
                    "{thesis:?} is not a name `place` reads a role from (landmarks {}; lips and \
                     lids {})",
                    LANDMARK_NAMES.join(", "),
                    FEATURE_MARKERS.map(|f| f.0).join(", ")
                ),
            ));
        }
        let Some(i) = actor_names.iter().position(|n| n == actor) else {
            return Err(bad(
                actor,
                thesis,
                format!("the actor has no marker {actor:?}"),
            ));
        };
        if let Some(other) = actor_names.iter().find(|n| *n == thesis && *n != actor) {
            return Err(bad(
                actor,
                thesis,
                format!("the actor's marker {other:?} already has that name"),
            ));
        }
        if let Some((first, _)) = aliases.iter().find(|(a, t)| t == thesis && a != actor) {
            return Err(bad(
                actor,
                thesis,
                format!("{first:?} is {thesis:?} already"),
            ));
        }
        if aliases.iter().filter(|(a, _)| a == actor).count() > 1 {
            return Err(bad(actor, thesis, format!("{actor:?} is aliased twice")));
        }
        names[i] = thesis.clone();
    }
    let thesis_of = |name: &str| {
        aliases
            .iter()
            .find(|(a, _)| a == name)
            .map_or_else(|| name.to_string(), |(_, t)| t.clone())
    };
    let pins: Vec<(String, u32)> = pins.iter().map(|(n, v)| (thesis_of(n), *v)).collect();
    let mut layout = place(mesh, &names, actor_neutral, &pins)?;
    for m in &mut layout.markers {
        if let Some((actor, _)) = aliases.iter().find(|(_, t)| *t == m.name) {
            m.name = actor.clone();
        }
    }
    Ok(layout)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::capture::read_capture;
    use crate::io::gltf_mesh::load_mesh;
    use crate::io::layout::read_layout;
    use crate::mesh::distance;
    use crate::model::place_markers;
    use std::path::Path;

    fn fixture(name: &str) -> std::path::PathBuf {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures")).join(name)
    }

    /// Regression pins for the pairwise-distance similarity of the placed face to the scaled
    /// actor (relative deviation, mean and 90th percentile).
    /// The lip and eyelid markers sit on their features ([`snap_to_features`]), not where the
    /// warp puts them, which moves them from the scaled actor's proportions.
    const PAIRWISE_MEAN: f64 = 0.23;
    const PAIRWISE_P90: f64 = 0.43;

    /// The committed FaceCap layout for JawMoCap's 41 markers is what placement produces, and it
    /// passes the checks that say the markers landed where their names say.
    #[test]
    fn facecap_layout_for_jawmocap_is_reproducible_and_plausible() {
        let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None).unwrap();
        let cap = read_capture(&fixture("JawMoCap.trc")).unwrap();
        let neutral: Vec<[f64; 3]> = cap.frames[0].iter().map(|p| p.unwrap()).collect();
        let layout = place(&mesh, &cap.marker_names, &neutral, &[]).unwrap();
        let committed = read_layout(&fixture("facecap_jawmocap_layout.toml")).unwrap();
        assert_eq!(committed.markers.len(), 41);
        for (a, b) in layout.markers.iter().zip(&committed.markers) {
            assert_eq!(a.name, b.name);
            let pos = |m: &LayoutMarker| match m.anchor {
                MarkerAnchor::Vertex(v) => mesh.positions[v as usize],
                MarkerAnchor::Point(p) => p,
            };
            assert!(
                distance(&pos(a), &pos(b)) < 1e-9,
                "{} moved: regenerate the fixture",
                a.name
            );
        }
        let placed = place_markers(&committed, &mesh, 1e-6).unwrap();
        let at = |n: &str| placed.iter().find(|m| m.name == n).unwrap().position;
        let actor_at = |n: &str| neutral[cap.marker_index(n).unwrap()];
        let scale = distance(&at("Leye_Outside"), &at("Reye_Outside"))
            / distance(&actor_at("Leye_Outside"), &actor_at("Reye_Outside"));
        // Left/right pairs mirror each other across x = 0 as well as the actor's own markers do
        // (FaceCap is symmetric; hand-placed markers on a real face are not): the placed pair's
        // gap from mirror images is at most the actor's gap, scaled to the character, + 4 mm.
        let mid = actor_at("NoseHead")[0];
        for (l, r) in [
            ("ForeHead_L", "ForeHead_R"),
            ("Leyebrow_M", "Reyebrow_M"),
            ("Leye_Up", "Reye_Up"),
            ("Leye_Down", "Reye_Down"),
            ("Lcheek_Up", "Rcheek_Up"),
            ("Lcheek_Outside", "Rcheek_Outside"),
            ("Mouth_UpL1", "Mouth_UpR1"),
            ("Mouth_DownL", "Mouth_DownR"),
            ("Chin_L1", "Chin_R1"),
            ("Chin_L2", "Chin_R2"),
            ("NoseHead_L", "NoseHead_R"),
        ] {
            let (pl, pr) = (at(l), at(r));
            let gap = distance(&pl, &[-pr[0], pr[1], pr[2]]);
            let (al, ar) = (actor_at(l), actor_at(r));
            let actor_gap =
                distance(&[al[0] - mid, al[1], al[2]], &[mid - ar[0], ar[1], ar[2]]) * scale;
            println!(
                "{l:16} mirror gap {:5.1} mm, the actor's own {:5.1} mm",
                gap * 1000.0,
                actor_gap * 1000.0
            );
            assert!(
                pl[0] > 0.0 && pr[0] < 0.0,
                "{l} must be on the subject's left (+x)"
            );
            assert!(
                gap < actor_gap + 0.004,
                "{l}/{r}: {:.1} mm from mirror images",
                gap * 1000.0
            );
        }
        // Vertical order of the face: forehead above brows above eyes above nose tip above
        // mouth above chin.
        let y = |n: &str| at(n)[1];
        let order = [
            "ForeHead_M",
            "Eyebrow_Center",
            "NoseTop",
            "NoseHead",
            "Mouth_Up",
            "Mouth_Down",
            "Chin",
        ];
        for w in order.windows(2) {
            assert!(y(w[0]) > y(w[1]), "{} should be above {}", w[0], w[1]);
        }
        // The placed face is the actor's face scaled: every pair of markers keeps its distance
        // (scaled by the eye-corner ratio) up to the two faces' real difference in shape.
        let names = &cap.marker_names;
        let mut deviations = Vec::new();
        for i in 0..names.len() {
            for j in i + 1..names.len() {
                let actor = distance(&actor_at(&names[i]), &actor_at(&names[j])) * scale;
                let placed_d = distance(&at(&names[i]), &at(&names[j]));
                deviations.push((placed_d - actor).abs() / actor);
            }
        }
        deviations.sort_by(f64::total_cmp);
        let mean = deviations.iter().sum::<f64>() / deviations.len() as f64;
        let p90 = deviations[deviations.len() * 9 / 10];
        println!(
            "pairwise distances vs the scaled actor: mean {:.1} %, p90 {:.1} %",
            mean * 100.0,
            p90 * 100.0
        );
        // The faces differ in proportions (FaceCap's mouth is narrower for its eye width), so this
        // is a regression pin, not a bar: measured 2026-11-22 (see the print above).
        assert!(
            mean < PAIRWISE_MEAN && p90 < PAIRWISE_P90,
            "mean {mean}, p90 {p90}"
        );
        // Lips on their own side of the opening: what the lip masks will rest on.
        let topo = crate::openings::seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
        let lips = topo.loops_of(0)[1];
        let lip_y = lips
            .vertices
            .iter()
            .map(|&v| mesh.welded_positions[v as usize][1])
            .sum::<f64>()
            / lips.vertices.len() as f64;
        for upper in ["Mouth_Up", "Mouth_UpL1", "Mouth_UpR1"] {
            assert!(y(upper) > lip_y, "{upper} must be above the lip opening");
        }
        for lower in ["Mouth_Down", "Mouth_DownL", "Mouth_DownR"] {
            assert!(y(lower) < lip_y, "{lower} must be below the lip opening");
        }
        // Every lip and eyelid marker on its lip or lid: within 0.15 × the opening's width of
        // its rim (the chin crease and the brow bone are 0.5 and 0.45 of it away), and on its
        // own side of the opening's centre.
        let openings = face_openings(&mesh).unwrap();
        for &(name, feature, upper, _) in &FEATURE_MARKERS {
            let rim = &openings[feature as usize];
            let pts: Vec<[f64; 3]> = rim
                .iter()
                .map(|&v| mesh.welded_positions[v as usize])
                .collect();
            let (lo, hi) = pts
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p[0]), hi.max(p[0]))
                });
            let near = pts
                .iter()
                .map(|p| distance(p, &at(name)))
                .fold(f64::INFINITY, f64::min);
            println!("{name:12} {:4.1} mm from its rim", near * 1000.0);
            assert!(near < 0.15 * (hi - lo), "{name} is {near} from its opening");
            let centre_y = pts.iter().map(|p| p[1]).sum::<f64>() / pts.len() as f64;
            assert_eq!(y(name) > centre_y, upper, "{name} on the wrong side");
        }
    }

    /// A capture with its own names (here JawMoCap's with a prefix) places as the thesis' names
    /// do once its markers with a role are aliased: the same anchors, under the actor's names.
    /// Without the aliases it has no landmarks; a bad alias names itself and what is wrong.
    #[test]
    fn a_capture_with_other_names_places_through_aliases() {
        let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None).unwrap();
        let cap = read_capture(&fixture("JawMoCap.trc")).unwrap();
        let neutral: Vec<[f64; 3]> = cap.frames[0].iter().map(|p| p.unwrap()).collect();
        let thesis = place(&mesh, &cap.marker_names, &neutral, &[("Chin".into(), 802)]).unwrap();
        let renamed: Vec<String> = cap.marker_names.iter().map(|n| format!("X_{n}")).collect();
        let aliases: Vec<(String, String)> = cap
            .marker_names
            .iter()
            .filter(|n| has_role(n))
            .map(|n| (format!("X_{n}"), n.clone()))
            .collect();
        assert_eq!(aliases.len(), 17);
        let pins = [("X_Chin".to_string(), 802)];
        let aliased = place_aliased(&mesh, &renamed, &neutral, &pins, &aliases).unwrap();
        assert_eq!(aliased.markers.len(), thesis.markers.len());
        for (a, t) in aliased.markers.iter().zip(&thesis.markers) {
            assert_eq!(a.name, format!("X_{}", t.name));
            assert_eq!(a.anchor, t.anchor, "{}", a.name);
        }
        let err = |aliases: &[(String, String)]| {
            place_aliased(&mesh, &renamed, &neutral, &[], aliases)
                .unwrap_err()
                .to_string()
        };
        let e = err(&[]);
        assert!(e.contains("Mouth_Lend"), "{e}");
        let pair = |a: &str, t: &str| (a.to_string(), t.to_string());
        let e = err(&[pair("X_Chin", "Chin")]);
        assert!(e.contains("X_Chin=Chin") && e.contains("not a name"), "{e}");
        let e = err(&[pair("Nope", "NoseHead")]);
        assert!(e.contains("no marker \"Nope\""), "{e}");
        let e = err(&[pair("X_Chin", "NoseHead"), pair("X_NoseHead", "NoseHead")]);
        assert!(e.contains("already"), "{e}");
        let e = err(&[pair("X_Chin", "NoseHead"), pair("X_Chin", "Mouth_Up")]);
        assert!(e.contains("twice"), "{e}");
        let e = place_aliased(
            &mesh,
            &cap.marker_names,
            &neutral,
            &[],
            &[pair("Chin", "NoseHead")],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("\"NoseHead\" already has that name"), "{e}");
    }
}
