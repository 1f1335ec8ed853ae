//! The mesh's own shapes as a probe with a truth. A mesh with morph targets says how its skin
//! moves: each target that moves the skin, at full weight, is an expression whose every vertex
//! is known. The bake reads the markers off each one, plays them through the rig it made and
//! measures the rig against the target, as the structure metrics measure a take against its
//! truth: a skin edge stretched past twice its length in the target (or at rest, if longer),
//! and skin triangles turned over that the target keeps upright.
//!
//! Two uses: the mouth corners' share (`super::mouth_share`) is the first whose rig stretches no
//! edge of any target where the linear profile does not; and every finished rig is checked
//! ([`ShapesCheck`], in the bake's report). A rig that tears a target in an expert's form (any
//! deformer or method but the default's linear deformer on surface distances) is refused by
//! `facebake bake` unless `--allow-tears` ([`ShapesCheck::refuses`]); the default, which has
//! nothing to fall back on, warns. Flips are reported, not refused: a target at full weight
//! need not be a face (FaceCap's `mouthClose` alone pushes the lips through each other, and
//! every form turns 6 to 8 skin triangles over in it).
//!
//! Measured 2026-12-06 (session 22), the JawMoCap layout (`place`d on ICT-FaceKit): the
//! largest stretch against any target, and the targets stretched past 2× (scratch harness over
//! `BakeReport::shapes`; the CLI's forms):
//!
//! | form | FaceCap (51 targets) | ICT-FaceKit (22) |
//! |---|---|---|
//! | the default | 1.81×, none | 1.97×, none |
//! | `--method hybrid` | 1.81×, none | 2.00×, none |
//! | `--method pbw` | 1.86×, none | 2.09×: `mouthLeft` (refused) |
//! | `--method euclidean` | 1.73×, none | 2.97×: the funnel, the pucker, the smiles, `mouthLeft` (refused) |
//! | `--deformer planar` | 2.21×: `jawOpen`, `mouthClose`, `mouthStretch_R` (refused) | 5.51×: 9 targets (refused) |
//! | `--deformer rbf` | 7.57×: 8 targets, `jawOpen` the worst (refused) | – |
//! | the papers' bare Euclidean RBF | 12.59×: 14 targets (refused) | 14.62×: 4 targets (refused) |

use facebake_runtime::{Rig, Space};
use serde::Serialize;

use super::mouth_share::{judged_edges, length};
use super::BakeError;
use crate::deformer::DeformerKind;
use crate::metrics::{Regions, STRETCH_LIMIT};
use crate::model::FaceMesh;
use crate::options::{BakeOptions, Method};
use crate::surface::SurfaceMarker;

/// The mesh's own shapes as a probe (see the module docs): its morph targets that move the
/// skin, each played at full weight, its markers read off it.
pub struct Shapes<'a> {
    mesh: &'a FaceMesh,
    regions: Regions,
    judged: Vec<[u32; 2]>,
    /// Each target played and its markers (rig units).
    targets: Vec<(usize, Vec<[i32; 3]>)>,
    /// Targets that move a marker out of the rig's range, left out.
    left_out: Vec<String>,
}

/// A finished rig measured against the mesh's own shapes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShapesCheck {
    /// The shapes played.
    pub shapes: usize,
    /// Shapes left out: they move a marker out of the rig's range.
    pub left_out: Vec<String>,
    /// The largest stretch of a judged skin edge against its length in the shape (or at rest,
    /// if longer), and the shape.
    pub max_stretch: (f64, String),
    /// The shapes in which an edge stretches past [`STRETCH_LIMIT`], each with its largest
    /// stretch.
    pub torn: Vec<(String, f64)>,
    /// The most skin triangles turned over in one shape that the shape keeps upright, and the
    /// shape.
    pub max_flipped: (usize, String),
}

impl ShapesCheck {
    /// Whether `facebake bake` refuses the rig baked with `options` (see the module docs): it
    /// tears a shape and is not the default's form.
    pub fn refuses(&self, options: &BakeOptions) -> bool {
        let default_form =
            options.deformer == DeformerKind::Linear && options.method == Method::Geodesic;
        !self.torn.is_empty() && !default_form
    }

    /// The tears as a sentence: each torn shape with its stretch, worst first.
    pub fn tears(&self) -> String {
        let mut torn = self.torn.clone();
        torn.sort_by(|a, b| b.1.total_cmp(&a.1));
        let each: Vec<String> = torn
            .iter()
            .map(|(name, stretch)| format!("{name} {stretch:.2}×"))
            .collect();
        format!(
            "the rig stretches a skin edge past {STRETCH_LIMIT}× its length in {} of the mesh's {} own shapes ({})",
            torn.len(),
            self.shapes,
            each.join(", ")
        )
    }
}

/// The rig in `blob`, just baked.
fn load(blob: &[u8]) -> Result<Rig<'_>, BakeError> {
    Rig::from_bytes(blob)
        .map_err(|e| BakeError::Input(format!("the rig just baked does not load: {e}")))
}

impl<'a> Shapes<'a> {
    /// The probe of `mesh`'s shapes with `markers` in the rig's `space`; `None` without morph
    /// targets that move the skin, or without a skin the metrics can measure.
    pub fn new(mesh: &'a FaceMesh, markers: &[SurfaceMarker], space: &Space) -> Option<Self> {
        if mesh.morph_targets.is_empty() {
            return None;
        }
        let regions = Regions::for_mesh(mesh, &[], &[]).ok()?;
        let mut skin = vec![false; mesh.positions.len()];
        for &[a, b] in &regions.edges {
            skin[a as usize] = true;
            skin[b as usize] = true;
        }
        let (mut targets, mut left_out) = (Vec::new(), Vec::new());
        for (t, target) in mesh.morph_targets.iter().enumerate() {
            let moves_skin =
                (target.deltas.iter().zip(&skin)).any(|(d, &on)| on && d.iter().any(|x| *x != 0.0));
            if !moves_skin {
                continue;
            }
            let moved: Option<Vec<[i32; 3]>> = markers
                .iter()
                .map(|m| {
                    let mut p = [0.0; 3];
                    for (v, w) in m.source.corners(&mesh.triangles) {
                        let (rest, delta) = (mesh.positions[v as usize], target.deltas[v as usize]);
                        for c in 0..3 {
                            p[c] += w * (rest[c] + delta[c]);
                        }
                    }
                    space.to_rig_f64(p).ok()
                })
                .collect();
            match moved {
                Some(moved) => targets.push((t, moved)),
                None => left_out.push(target.name.clone()),
            }
        }
        if targets.is_empty() {
            return None;
        }
        let judged = judged_edges(&regions);
        Some(Self {
            mesh,
            regions,
            judged,
            targets,
            left_out,
        })
    }

    /// How many shapes it plays.
    pub fn count(&self) -> usize {
        self.targets.len()
    }

    /// The shapes the rig in `blob` tears: a judged skin edge stretched past twice its length
    /// in the shape (or at rest, if longer) that the rig in `linear`, when given, keeps within
    /// it.
    pub fn torn(&self, blob: &[u8], linear: Option<&[u8]>) -> Result<usize, BakeError> {
        let rest = self.regions.rest();
        let mut torn = 0;
        self.play(blob, linear, |_, truth, got, base| {
            let allowed = |e| STRETCH_LIMIT * length(truth, e).max(length(rest, e));
            torn += usize::from(self.judged.iter().any(|&e| {
                length(got, e) > allowed(e) && base.is_none_or(|b| length(b, e) <= allowed(e))
            }));
        })?;
        Ok(torn)
    }

    /// The rig in `blob` measured against every shape.
    pub fn check(&self, blob: &[u8]) -> Result<ShapesCheck, BakeError> {
        let rest = self.regions.rest();
        let mut check = ShapesCheck {
            shapes: self.count(),
            left_out: self.left_out.clone(),
            max_stretch: (0.0, String::new()),
            torn: Vec::new(),
            max_flipped: (0, String::new()),
        };
        self.play(blob, None, |name, truth, got, _| {
            let stretch = self
                .judged
                .iter()
                .map(|&e| length(got, e) / length(truth, e).max(length(rest, e)))
                .filter(|r| r.is_finite())
                .fold(0.0, f64::max);
            if stretch > check.max_stretch.0 {
                check.max_stretch = (stretch, name.to_string());
            }
            if stretch > STRETCH_LIMIT {
                check.torn.push((name.to_string(), stretch));
            }
            let turned = |p: &[[f64; 3]], t: &[u32; 3]| self.regions.turned(p, t);
            let flipped = (self.regions.triangles.iter())
                .filter(|t| turned(got, t) && !turned(truth, t))
                .count();
            if flipped > check.max_flipped.0 {
                check.max_flipped = (flipped, name.to_string());
            }
        })?;
        Ok(check)
    }

    /// Play each shape through the rig in `blob` (and `linear`'s, when given) and hand `each`
    /// the shape's name, its true vertices and the rigs' (asset units, glTF order). One shape's
    /// vertices at a time.
    fn play(
        &self,
        blob: &[u8],
        linear: Option<&[u8]>,
        mut each: impl FnMut(&str, &[[f64; 3]], &[[f64; 3]], Option<&[[f64; 3]]>),
    ) -> Result<(), BakeError> {
        let rig = load(blob)?;
        let linear = linear.map(load).transpose()?;
        let play = |rig: &Rig<'_>, markers: &[[i32; 3]]| -> Result<Vec<[f64; 3]>, BakeError> {
            let mut out = vec![[0; 3]; rig.vertex_count()];
            rig.deform(markers, &mut out).map_err(|e| {
                BakeError::Input(format!("the rig just baked does not play a shape: {e}"))
            })?;
            let space = rig.space();
            Ok(out.iter().map(|&q| space.to_asset_f64(q)).collect())
        };
        for (t, markers) in &self.targets {
            let name = &self.mesh.morph_targets[*t].name;
            let truth = self.mesh.morphed(&[(*t, 1.0)]);
            let got = play(&rig, markers)?;
            let base = linear.as_ref().map(|l| play(l, markers)).transpose()?;
            each(name, &truth, &got, base.as_deref());
        }
        Ok(())
    }
}
