//! The face's own axes, found from its openings, so that what the bake decides by direction
//! ("above the mouth", "the mouth's corners across the face", "the upper lip") means the same on
//! a head that is tilted, turned or rolled in its file as on one that faces +Z with +Y up.
//!
//! The eyes and the mouth are those of [`crate::openings::mouth_and_eyes`]. `right` runs from
//! one eye to the other (the one at smaller x first, so an upright face keeps its x): a roll or
//! a turn of the head in its file is read from the eyes exactly. `up` is square to it. How far the head is pitched needs an anatomical reference:
//! the line from the mouth's centre to the midpoint of the eyes leans back from the vertical by
//! [`PROFILE_LEAN`] (the mouth sits in front of the eyes' openings; FaceCap's measure). Faces
//! differ in this by a few degrees, so the file's own pitch (square to `right`, nearest +Y) is
//! kept unless the features say it is off by more than [`PITCH_TRUSTED`]; then the features'
//! pitch is taken. `front` is `right × up`. A face whose openings do not give these (fewer than
//! three, or a "mouth" not below the eyes: more than 60° from the file's +Y) keeps the file's
//! axes.
//!
//! Only the bake's directional rules read positions in these axes; distances do not change, and
//! the rig's own positions (its affine part) stay in the file's. Its derived markers take `up`
//! as their direction (`deformer::linear::derived_direction`), so the mouth's corners open
//! along the face's vertical.

use crate::mesh::{cross, dot, sub, unit};
use crate::model::FaceMesh;

use crate::openings::{find_openings, mouth_and_eyes, Opening};

/// The smallest cosine between the face's `up` and the file's +Y that is taken as the face's
/// (60°): beyond it the openings are not read as eyes above a mouth.
const MIN_UPRIGHT: f64 = 0.5;

/// How far the line from the mouth to the eyes leans back from the face's vertical: 13.5° on
/// FaceCap's head (its openings' centres), whose file is upright.
pub const PROFILE_LEAN: f64 = 13.5;

/// The largest pitch, in degrees, between the file's vertical and the one the features give
/// that is put down to the face's own proportions rather than to the file's pose. Tilting
/// FaceCap by 0.1 / 0.2 / 0.35 rad (5.7°, 11.5°, 20°) about its x axis moved its static skin
/// 0.40 / 0.46 / 0.50 mm one way and up to 17 mm the other, against 0.34 mm upright.
pub const PITCH_TRUSTED: f64 = 10.0;

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
        let openings = find_openings(&mesh.welded_topology(), &mesh.welded_positions);
        Self::from_openings(&openings)
    }

    /// The frame of these openings (see the module docs), else [`Self::FILE`].
    pub fn from_openings(openings: &[Opening]) -> Self {
        let Some((mouth, eyes)) = mouth_and_eyes(openings) else {
            return Self::FILE;
        };
        let middle = [0, 1, 2].map(|i| 0.5 * (eyes[0].centre[i] + eyes[1].centre[i]));
        let Some(right) = unit(&sub(&eyes[1].centre, &eyes[0].centre)) else {
            return Self::FILE;
        };
        let square = |v: [f64; 3]| unit(&sub(&v, &right.map(|r| r * dot(&v, &right))));
        let (Some(file_up), Some(features)) =
            (square([0.0, 1.0, 0.0]), square(sub(&middle, &mouth.centre)))
        else {
            return Self::FILE;
        };
        // The features' line leans back by PROFILE_LEAN: turn it forwards about `right`.
        let (sin, cos) = PROFILE_LEAN.to_radians().sin_cos();
        let forwards = cross(&right, &features);
        let features_up = [0, 1, 2].map(|i| cos * features[i] + sin * forwards[i]);
        if features_up[1] < MIN_UPRIGHT {
            return Self::FILE;
        }
        let pitch = dot(&file_up, &features_up)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        let up = if pitch > PITCH_TRUSTED {
            features_up
        } else {
            file_up
        };
        Self {
            axes: [right, up, cross(&right, &up)],
        }
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

    #[test]
    fn an_upright_face_keeps_its_axes_and_a_rolled_one_is_turned_back() {
        let face = |roll: f64| {
            let turn = |p: [f64; 3]| {
                let (s, c) = roll.sin_cos();
                [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
            };
            // The mouth in front of the eyes by tan(13.5°) of its drop.
            let ahead = 0.07 * PROFILE_LEAN.to_radians().tan();
            vec![
                opening(turn([0.0, -0.07, ahead]), 0.12),
                opening(turn([-0.03, 0.0, 0.0]), 0.07),
                opening(turn([0.03, 0.0, 0.0]), 0.072),
            ]
        };
        let upright = FaceFrame::from_openings(&face(0.0));
        for (row, want) in upright.axes.iter().zip(FaceFrame::FILE.axes) {
            for (x, y) in row.iter().zip(want) {
                assert!((x - y).abs() < 1e-12, "{upright:?}");
            }
        }
        let rolled = FaceFrame::from_openings(&face(0.3));
        assert!((rolled.tilt_degrees() - 0.3f64.to_degrees()).abs() < 1e-9);
        assert!((rolled.turn_degrees() - 0.3f64.to_degrees()).abs() < 1e-6);
        assert_eq!(upright.turn_degrees(), 0.0);
        // Pitched by 5° the file's vertical is kept; by 20°, the features' is taken.
        let pitched = |degrees: f64| {
            let (s, c) = degrees.to_radians().sin_cos();
            let turn = |p: [f64; 3]| [p[0], c * p[1] - s * p[2], s * p[1] + c * p[2]];
            let openings: Vec<Opening> = face(0.0)
                .into_iter()
                .map(|o| opening(turn(o.centre), o.length))
                .collect();
            FaceFrame::from_openings(&openings).tilt_degrees()
        };
        assert!(pitched(5.0) < 1e-9);
        assert!((pitched(20.0) - 20.0).abs() < 1e-9, "{}", pitched(20.0));
        // The rolled face's left eye, read in its own axes, sits level with the right one.
        let eyes = face(0.3);
        let (l, r) = (rolled.local(&eyes[1].centre), rolled.local(&eyes[2].centre));
        assert!((l[1] - r[1]).abs() < 1e-12 && l[0] < r[0]);
    }

    #[test]
    fn without_eyes_above_a_mouth_the_file_axes_stay() {
        assert_eq!(FaceFrame::from_openings(&[]), FaceFrame::FILE);
        // Upside down: the "mouth" is above the eyes.
        let flipped = [
            opening([0.0, 0.07, 0.0], 0.12),
            opening([-0.03, 0.0, 0.0], 0.07),
            opening([0.03, 0.0, 0.0], 0.07),
        ];
        assert_eq!(FaceFrame::from_openings(&flipped), FaceFrame::FILE);
    }
}
