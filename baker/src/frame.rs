//! The face's own axes, found from its openings, so that what the bake decides by direction
//! ("above the mouth", "the mouth's corners across the face", "the upper lip") means the same on
//! a head that is tilted, turned or rolled in its file as on one that faces +Z with +Y up.
//!
//! The eyes and the mouth are those of [`crate::openings::mouth_and_eyes`]. `right` runs from
//! one eye to the other: a roll or a turn of the head in its file is read from the eyes exactly.
//! Which eye comes first is decided by the head's bulk: `front` (below) must point from the
//! centroid of the skin towards the mouth, so a face towards −Z, upside down or with +Z up in its
//! file is read as the face it is (an upright face towards +Z keeps its x; so does a skin whose
//! centroid is within a tenth of the eyes' spacing of the mouth's depth, a flat mask). `up` is
//! square to it. How far the head is pitched needs an anatomical reference:
//! the line from the mouth's centre to the midpoint of the eyes leans back from the vertical by
//! [`PROFILE_LEAN`] (the mouth sits in front of the eyes' openings; FaceCap's measure). Faces
//! differ in this by a few degrees, so the file's own pitch (square to `right`, nearest +Y) is
//! kept unless the features say it is off by more than [`PITCH_TRUSTED`]; then the features'
//! pitch is taken; when the file's +Y is more than 60° from the features' vertical (a file
//! with +Z up, a head upside down) the features' vertical is taken whatever the pitch. `front` is
//! `right × up`. A face whose openings do not give these (fewer than three, or a mouth not
//! between the eyes' sides, below them by 0.5 to 3 eye spacings) keeps the file's axes.
//!
//! Only the bake's directional rules read positions in these axes; distances do not change, and
//! the rig's own positions (its affine part) stay in the file's. Its derived markers take `up`
//! as their direction (`deformer::linear::derived_direction`), so the mouth's corners open
//! along the face's vertical.

use crate::mesh::{cross, dot, sub, unit};
use crate::model::FaceMesh;

use crate::openings::{mouth_and_eyes, skin_openings, Opening};

/// The smallest cosine between the features' vertical and the file's +Y for which the file's
/// pitch may be kept (60°): beyond it the file's +Y is not the face's up at all.
const MIN_UPRIGHT: f64 = 0.5;

/// How far the line from the mouth to the eyes leans back from the face's vertical: 13.5° on
/// FaceCap's head (its openings' centres), whose file is upright.
pub const PROFILE_LEAN: f64 = 13.5;

/// The largest pitch, in degrees, between the file's vertical and the one the features give
/// that is put down to the face's own proportions rather than to the file's pose. Tilting
/// FaceCap by 0.1 / 0.2 / 0.35 rad (5.7°, 11.5°, 20°) about its x axis moved its static skin
/// 0.40 / 0.46 / 0.50 mm one way and up to 17 mm the other, against 0.34 mm upright.
pub const PITCH_TRUSTED: f64 = 10.0;

/// Whether `mesh`'s skin has a mouth and two eyes ([`FaceFrame::find`]): how a file's face is
/// told from its eyes, teeth and body.
pub fn has_face(mesh: &FaceMesh) -> bool {
    let openings = skin_openings(
        &mesh.welded_topology(),
        &mesh.welded_positions,
        &mesh.welded_triangles,
    );
    FaceFrame::find(&openings, crate::mesh::mean(&mesh.welded_positions)).is_some()
}

/// The face's axes in the file's coordinates: rows `right`, `up`, `front`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceFrame {
    axes: [[f64; 3]; 3],
}

impl FaceFrame {
    /// The file's own axes.
    pub const FILE: Self = Self {
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// The frame of `mesh`'s openings (see the module docs), else [`Self::FILE`].
    pub fn of(mesh: &FaceMesh) -> Self {
        let openings = skin_openings(
            &mesh.welded_topology(),
            &mesh.welded_positions,
            &mesh.welded_triangles,
        );
        Self::from_openings(&openings, crate::mesh::mean(&mesh.welded_positions))
    }

    /// The frame of these openings on a skin whose vertices' centroid is `bulk` (see the module
    /// docs), else [`Self::FILE`].
    pub fn from_openings(openings: &[Opening], bulk: [f64; 3]) -> Self {
        Self::find(openings, bulk).unwrap_or(Self::FILE)
    }

    /// The frame of these openings on a skin whose vertices' centroid is `bulk`, if they are a
    /// mouth and two eyes (see the module docs).
    pub fn find(openings: &[Opening], bulk: [f64; 3]) -> Option<Self> {
        let (mouth, eyes) = mouth_and_eyes(openings)?;
        let middle = [0, 1, 2].map(|i| 0.5 * (eyes[0].centre[i] + eyes[1].centre[i]));
        let across = sub(&eyes[1].centre, &eyes[0].centre);
        let mut right = unit(&across)?;
        if !crate::openings::below_eyes(&mouth.centre, [&eyes[0].centre, &eyes[1].centre]) {
            return None;
        }
        let spacing = dot(&across, &across).sqrt();
        let drop = sub(&middle, &mouth.centre);
        let square =
            |v: [f64; 3], right: &[f64; 3]| unit(&sub(&v, &right.map(|r| r * dot(&v, right))));
        let features = square(drop, &right)?;
        // `front` points from the skin's bulk towards the mouth: else the eyes come the other
        // way round. A skin with its bulk level with the mouth (a flat mask) says nothing: the
        // eye at smaller x stays first.
        if dot(&cross(&right, &features), &sub(&mouth.centre, &bulk)) < -0.1 * spacing {
            right = right.map(|r| -r);
        }
        // The features' line leans back by PROFILE_LEAN: turn it forwards about `right`.
        let (sin, cos) = PROFILE_LEAN.to_radians().sin_cos();
        let forwards = cross(&right, &features);
        let features_up = [0, 1, 2].map(|i| cos * features[i] + sin * forwards[i]);
        let file_up = square([0.0, 1.0, 0.0], &right).filter(|_| features_up[1] >= MIN_UPRIGHT);
        let pitch = file_up.map_or(180.0, |f| {
            dot(&f, &features_up).clamp(-1.0, 1.0).acos().to_degrees()
        });
        let up = match file_up {
            Some(f) if pitch <= PITCH_TRUSTED => f,
            _ => features_up,
        };
        Some(Self {
            axes: [right, up, cross(&right, &up)],
        })
    }

    /// The axes in file coordinates: rows `right`, `up`, `front`.
    pub fn axes(&self) -> [[f64; 3]; 3] {
        self.axes
    }

    /// `p` (file coordinates) in the face's axes.
    pub fn local(&self, p: &[f64; 3]) -> [f64; 3] {
        self.axes.map(|axis| dot(&axis, p))
    }

    /// `p` (the face's axes) in file coordinates: the inverse of [`Self::local`].
    pub fn file(&self, p: &[f64; 3]) -> [f64; 3] {
        let [r, u, f] = self.axes;
        [0, 1, 2].map(|i| r[i] * p[0] + u[i] * p[1] + f[i] * p[2])
    }

    /// `points` (file coordinates) in the face's axes.
    pub fn points(&self, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
        points.iter().map(|p| self.local(p)).collect()
    }

    /// A copy of `mesh` with every position and normal in the face's axes, without its morph
    /// targets (the bake's rules do not read them).
    pub fn mesh(&self, mesh: &FaceMesh) -> FaceMesh {
        let local = |points: &[[f64; 3]]| self.points(points);
        FaceMesh {
            source: mesh.source.clone(),
            mesh_name: mesh.mesh_name.clone(),
            mesh_index: mesh.mesh_index,
            primitive_index: mesh.primitive_index,
            positions: local(&mesh.positions),
            normals: mesh.normals.as_deref().map(local),
            triangles: mesh.triangles.clone(),
            weld: mesh.weld.clone(),
            welded_positions: local(&mesh.welded_positions),
            welded_triangles: mesh.welded_triangles.clone(),
            morph_targets: Vec::new(),
            attributes: mesh.attributes.clone(),
        }
    }

    /// How far the face's axes are turned from the file's, in degrees (the angle of the
    /// rotation between them).
    pub fn turn_degrees(&self) -> f64 {
        let trace = self.axes[0][0] + self.axes[1][1] + self.axes[2][2];
        (0.5 * (trace - 1.0)).clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// How far the face's `up` leans from the file's +Y, in degrees.
    pub fn tilt_degrees(&self) -> f64 {
        self.axes[1][1].clamp(-1.0, 1.0).acos().to_degrees()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opening(centre: [f64; 3], length: f64) -> Opening {
        Opening {
            vertices: Vec::new(),
            centre,
            length,
        }
    }

    /// Eyes and a mouth in front of them by tan(13.5°) of its drop, turned by `turn`, and the
    /// head's bulk 8 cm behind the eyes.
    fn face(turn: impl Fn([f64; 3]) -> [f64; 3]) -> (Vec<Opening>, [f64; 3]) {
        let ahead = 0.07 * PROFILE_LEAN.to_radians().tan();
        (
            vec![
                opening(turn([0.0, -0.07, ahead]), 0.12),
                opening(turn([-0.03, 0.0, 0.0]), 0.07),
                opening(turn([0.03, 0.0, 0.0]), 0.072),
            ],
            turn([0.0, 0.0, -0.08]),
        )
    }

    fn frame_of(turn: impl Fn([f64; 3]) -> [f64; 3]) -> FaceFrame {
        let (openings, bulk) = face(turn);
        FaceFrame::from_openings(&openings, bulk)
    }

    /// `p` turned by `angle` about the unit `axis` (Rodrigues).
    fn turned(axis: [f64; 3], angle: f64) -> impl Fn([f64; 3]) -> [f64; 3] {
        move |p| {
            let (s, c) = angle.sin_cos();
            let k = cross(&axis, &p);
            let along = dot(&axis, &p) * (1.0 - c);
            [0, 1, 2].map(|i| p[i] * c + k[i] * s + axis[i] * along)
        }
    }

    #[test]
    fn an_upright_face_keeps_its_axes_and_a_rolled_one_is_turned_back() {
        let upright = frame_of(|p| p);
        for (row, want) in upright.axes.iter().zip(FaceFrame::FILE.axes) {
            for (x, y) in row.iter().zip(want) {
                assert!((x - y).abs() < 1e-12, "{upright:?}");
            }
        }
        let rolled = frame_of(turned([0.0, 0.0, 1.0], 0.3));
        assert!((rolled.tilt_degrees() - 0.3f64.to_degrees()).abs() < 1e-9);
        assert!((rolled.turn_degrees() - 0.3f64.to_degrees()).abs() < 1e-6);
        assert_eq!(upright.turn_degrees(), 0.0);
        // Pitched by 5° the file's vertical is kept; by 20°, the features' is taken.
        let pitched =
            |degrees: f64| frame_of(turned([1.0, 0.0, 0.0], -degrees.to_radians())).tilt_degrees();
        assert!(pitched(5.0) < 1e-9);
        assert!((pitched(20.0) - 20.0).abs() < 1e-9, "{}", pitched(20.0));
        // The rolled face's left eye, read in its own axes, sits level with the right one.
        let (eyes, _) = face(turned([0.0, 0.0, 1.0], 0.3));
        let (l, r) = (rolled.local(&eyes[1].centre), rolled.local(&eyes[2].centre));
        assert!((l[1] - r[1]).abs() < 1e-12 && l[0] < r[0]);
    }

    /// A face towards −Z, upside down, with +Z up or lying on its side is read as the upright
    /// face turned: its axes are the turn's, whatever the file's.
    #[test]
    fn a_face_is_read_the_right_way_round_in_any_orientation() {
        use std::f64::consts::{FRAC_PI_2, PI};
        for (axis, angle) in [
            ([0.0, 1.0, 0.0], PI),
            ([0.0, 0.0, 1.0], PI),
            ([1.0, 0.0, 0.0], FRAC_PI_2),
            ([1.0, 0.0, 0.0], -FRAC_PI_2),
            ([0.0, 0.0, 1.0], FRAC_PI_2),
            ([0.0, 1.0, 0.0], 2.5),
        ] {
            let turn = turned(axis, angle);
            let frame = frame_of(&turn);
            for (row, file_axis) in frame.axes.iter().zip(FaceFrame::FILE.axes) {
                let want = turn(file_axis);
                for (x, y) in row.iter().zip(want) {
                    assert!((x - y).abs() < 1e-9, "{axis:?} {angle}: {frame:?}");
                }
            }
        }
    }

    /// A flat mask's bulk says nothing about its front: the eye at smaller x stays first.
    #[test]
    fn a_flat_mask_keeps_its_x() {
        let (openings, _) = face(|p| p);
        // 3 mm in front of the mouth, a twentieth of the eyes' spacing.
        let [x, y, z] = openings[0].centre;
        let frame = FaceFrame::from_openings(&openings, [x, y, z + 0.003]);
        assert!(
            frame.axes[0][0] > 0.99 && frame.axes[2][2] > 0.99,
            "{frame:?}"
        );
    }

    #[test]
    fn without_eyes_beside_a_mouth_the_file_axes_stay() {
        assert_eq!(FaceFrame::from_openings(&[], [0.0; 3]), FaceFrame::FILE);
        // A "mouth" level with the eyes, or far below them, or nearer one eye.
        for mouth in [[0.0, 0.0, 0.0], [0.0, -0.3, 0.0], [0.05, -0.05, 0.0]] {
            let openings = [
                opening(mouth, 0.12),
                opening([-0.03, 0.0, 0.0], 0.07),
                opening([0.03, 0.0, 0.0], 0.07),
            ];
            assert_eq!(
                FaceFrame::from_openings(&openings, [0.0, 0.0, -0.08]),
                FaceFrame::FILE,
                "{mouth:?}"
            );
        }
    }
}
