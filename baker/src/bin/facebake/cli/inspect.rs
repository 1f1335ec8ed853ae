//! `facebake inspect`: what a rig blob holds and what a frame costs.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use facebake_runtime::deformer::linear::{DerivedMarker, DIRECTION_ONE};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::records::HEADER_LEN;
use facebake_runtime::{Cost, Rig};
use serde::Serialize;

use facebake_runtime::stages::retarget::Retarget;

use super::bytes_text;
use super::{emit, load_rig, marker_names, print_json, read_file, weight_format, CliError};

/// Arguments of `facebake inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// The rig blob (.fbk).
    #[arg(value_name = "RIG")]
    pub rig: PathBuf,
    /// Print as JSON on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// The per-frame work of a rig ([`Cost`], serialisable).
#[derive(Debug, Serialize)]
pub struct CostSummary {
    /// Vertices written.
    pub vertices: usize,
    /// Markers read.
    pub markers: usize,
    /// Influences evaluated.
    pub influences: usize,
    /// Coefficient rows computed per frame (0 for linear rigs).
    pub coefficient_rows: usize,
    /// K.
    pub max_influences: usize,
    /// `i32 × i32 → i64` multiply-adds.
    pub multiply_adds: usize,
    /// Saturating subtractions.
    pub subtractions: usize,
    /// Narrowing steps.
    pub narrowings: usize,
    /// Stack scratch, bytes.
    pub scratch_bytes: usize,
    /// Control-triangle frames built per frame (planar bones).
    pub frame_builds: usize,
    /// Integer-square-root normalisations per frame (planar bones).
    pub normalisations: usize,
    /// The runtime's own one-line description.
    pub text: String,
    /// The work of one `Rig::normals` call, as the runtime describes it.
    pub normals: String,
}

impl From<Cost> for CostSummary {
    fn from(c: Cost) -> Self {
        Self {
            vertices: c.vertices,
            markers: c.markers,
            influences: c.influences,
            coefficient_rows: c.coefficient_rows,
            max_influences: c.max_influences,
            multiply_adds: c.multiply_adds,
            subtractions: c.subtractions,
            narrowings: c.narrowings,
            scratch_bytes: c.scratch_bytes,
            frame_builds: c.frame_builds,
            normalisations: c.normalisations,
            text: c.to_string(),
            normals: c.normals.to_string(),
        }
    }
}

/// Bytes of each part of a blob.
#[derive(Debug, Serialize)]
pub struct Sections {
    /// Fixed header (magic, version, length, CRC).
    pub header: usize,
    /// Marker names (length-prefixed UTF-8).
    pub marker_names: usize,
    /// Marker rest positions (3 × i32 each).
    pub marker_rest: usize,
    /// Vertex rest positions (3 × i16 each).
    pub vertex_rest: usize,
    /// Influence counts, or influence pair counts for linear rigs (1 byte per vertex).
    pub influence_counts: usize,
    /// Coefficient row shifts (1 byte per row; RBF-coefficient rigs).
    pub row_shifts: usize,
    /// Coefficient map (rows × markers × i16; RBF-coefficient rigs), the control triangles
    /// (3 bytes each; planar-bones rigs) or the marker pairs (2 bytes each; linear rigs).
    pub matrix: usize,
    /// Influences (4 bytes each; 20 for planar bones; 6 per pair of two for linear rigs).
    pub influences: usize,
    /// Capture stages' byte sections (neutral, head, fill, radii, coefficients).
    pub stages: usize,
    /// The normals section's byte sections (rest normals, fan counts, fan corners, welds).
    pub normals: usize,
    /// Everything else: the space, counts and postcard length prefixes.
    pub other: usize,
}

/// What `inspect` reports.
#[derive(Debug, Serialize)]
pub struct InspectSummary {
    /// The file.
    pub rig: PathBuf,
    /// Blob format version.
    pub format_version: u16,
    /// Blob size in bytes.
    pub blob_bytes: usize,
    /// The deformer, named as `bake --deformer` names it: "linear" (weights on marker
    /// displacements), "rbf" or "planar".
    pub deformer: &'static str,
    /// Whether an RBF-coefficient rig has the affine rows (`None` for linear rigs).
    pub affine: Option<bool>,
    /// Vertices.
    pub vertices: usize,
    /// Markers.
    pub markers: usize,
    /// Marker names, in marker order.
    pub marker_names: Vec<String>,
    /// K: the most influences of any vertex.
    pub k: usize,
    /// Stored influences.
    pub influences: usize,
    /// Mean influences per vertex.
    pub mean_influences_per_vertex: f64,
    /// Format of marker and output positions.
    pub position_format: &'static str,
    /// Format of stored vertex rest positions.
    pub rest_format: &'static str,
    /// Format of the stored weights (linear) or kernel values (RBF), `Q(23−F).F`.
    pub weight_format: String,
    /// F, their fractional bits.
    pub weight_frac_bits: u8,
    /// Centre of the rig space in asset units.
    pub space_centre: [f32; 3],
    /// One rig unit in asset units.
    pub space_half_extent: f32,
    /// Size breakdown.
    pub sections: Sections,
    /// Bytes per stored influence.
    pub bytes_per_influence: f64,
    /// Bytes per vertex of everything but the influences.
    pub other_bytes_per_vertex: f64,
    /// A linear rig's derived markers in order (marker M + j), each described: `"Mouth_Lend
    /// along [0, 1, 0]"` (its displacement projected on a direction) or `"mean of A, B, C"`.
    pub derived: Vec<String>,
    /// Per-frame cost.
    pub cost: CostSummary,
    /// Triangles in the rig's normals plan (`Rig::normals_plan_len`), for `Rig::normals_planned`.
    pub normals_plan_triangles: usize,
    /// Caller scratch `Rig::normals_planned` needs, bytes: the plan (12 a triangle) and one sum
    /// per vertex (24).
    pub normals_planned_scratch_bytes: usize,
    /// The capture stages, if the rig has them.
    pub capture: Option<CaptureSummary>,
}

/// The capture stages of a rig, for `inspect`.
#[derive(Debug, Serialize)]
pub struct CaptureSummary {
    /// Whether the stages were baked without a capture, from the rig's own markers at rest
    /// (`facebake::bake::at_rest`; known by their neutral pose, `play::stages_at_rest`).
    pub at_rest: bool,
    /// Head markers, by name (empty: no compensation).
    pub head_markers: Vec<String>,
    /// The actor's half extent, metres.
    pub actor_half_extent_m: f32,
    /// Largest plausible compensated displacement, metres.
    pub max_displacement_m: f64,
    /// Head-marker distance tolerance, metres.
    pub head_tolerance_m: f64,
    /// Largest plausible movement per frame, metres.
    pub max_step_m: f64,
    /// The smoothing's lag when still, frames; `None` without smoothing.
    pub smoothing_lag_frames: Option<u32>,
    /// The head refit's cutoff, metres; `None` without a refit (the head markers' fit alone).
    pub head_refit_m: Option<f64>,
    /// Per-frame work.
    pub cost: String,
}

/// Describe a loaded rig whose blob is `bytes`.
pub fn summarise(path: PathBuf, bytes: &[u8], rig: &Rig<'_>) -> InspectSummary {
    let data = rig.data();
    let (deformer, affine, counts, shifts, matrix, influences) = match rig.deformer() {
        Deformer::Linear(l) => (
            "linear",
            None,
            l.pair_counts.0.len(),
            0,
            l.marker_pairs.0.len(),
            l.pairs.0.len(),
        ),
        Deformer::Rbf(r) => (
            "rbf",
            Some(r.affine),
            0,
            r.row_shifts.0.len(),
            r.matrix.0.len(),
            r.influences.0.len(),
        ),
        Deformer::Planar(p) => (
            "planar",
            None,
            p.influence_counts.0.len(),
            0,
            p.triangles.0.len(),
            p.influences.0.len(),
        ),
    };
    let stages_bytes = data.stages.map_or(0, |st| {
        st.actor_neutral.0.len()
            + st.head_markers.0.len()
            + st.fill.0.len()
            + match st.retarget {
                Retarget::Rbf(r) => r.radii.0.len() + r.alpha.0.len(),
                Retarget::Proportional(p) => p.matrices.0.len() + p.rest.0.len(),
            }
    });
    let n = &data.normals;
    let normals_bytes = n.rest.0.len() + n.fan_counts.0.len() + n.corners.0.len() + n.welds.0.len();
    let known = stages_bytes
        + normals_bytes
        + HEADER_LEN
        + data.marker_names.0.len()
        + data.marker_rest.0.len()
        + data.vertex_rest.0.len()
        + counts
        + shifts
        + matrix
        + influences;
    let sections = Sections {
        header: HEADER_LEN,
        marker_names: data.marker_names.0.len(),
        marker_rest: data.marker_rest.0.len(),
        vertex_rest: data.vertex_rest.0.len(),
        influence_counts: counts,
        row_shifts: shifts,
        matrix,
        influences,
        stages: stages_bytes,
        normals: normals_bytes,
        other: bytes.len().saturating_sub(known),
    };
    let cost = rig.cost();
    let vertices = rig.vertex_count();
    let space = rig.space();
    InspectSummary {
        rig: path,
        // `Rig::from_bytes` checked the header, so the version field is there.
        format_version: u16::from_le_bytes([bytes[8], bytes[9]]),
        blob_bytes: bytes.len(),
        deformer,
        affine,
        vertices,
        markers: rig.marker_count(),
        marker_names: marker_names(rig),
        derived: derived_markers(rig),
        k: cost.max_influences,
        influences: cost.influences,
        mean_influences_per_vertex: cost.influences as f64 / vertices.max(1) as f64,
        position_format: "Q8.24",
        rest_format: "Q0.15",
        weight_format: if deformer == "planar" {
            "Q1.15 (unsigned 16-bit)".into()
        } else {
            weight_format(rig.weight_frac_bits())
        },
        weight_frac_bits: rig.weight_frac_bits(),
        space_centre: space.centre,
        space_half_extent: space.half_extent,
        bytes_per_influence: sections.influences as f64 / cost.influences.max(1) as f64,
        other_bytes_per_vertex: (bytes.len() - sections.influences) as f64 / vertices.max(1) as f64,
        sections,
        cost: cost.into(),
        normals_plan_triangles: rig.normals_plan_len(),
        normals_planned_scratch_bytes: size_of::<[u32; 3]>() * rig.normals_plan_len()
            + size_of::<[i64; 3]>() * vertices,
        capture: rig.stages().map(|st| {
            let c = st.cost();
            CaptureSummary {
                at_rest: super::play::stages_at_rest(rig),
                head_markers: st
                    .head_markers()
                    .iter()
                    .filter_map(|&h| rig.marker_names().nth(usize::from(h)))
                    .map(str::to_string)
                    .collect(),
                actor_half_extent_m: st.actor_space.half_extent,
                max_displacement_m: f64::from(st.max_displacement) / f64::from(1u32 << 24)
                    * f64::from(st.actor_space.half_extent),
                head_tolerance_m: f64::from(st.head_tolerance) / f64::from(1u32 << 24)
                    * f64::from(st.actor_space.half_extent),
                max_step_m: f64::from(st.max_step) / f64::from(1u32 << 24)
                    * f64::from(st.actor_space.half_extent),
                smoothing_lag_frames: st.smoothing.map(|f| f.still_lag_frames()),
                head_refit_m: (st.refit_cutoff > 0).then(|| {
                    f64::from(st.refit_cutoff) / f64::from(1u32 << 24)
                        * f64::from(st.actor_space.half_extent)
                }),
                cost: format!(
                    "{} markers: {} head-marker distance checks, at most {} rigid fits of {} head markers ({} 4×4 squarings), {} step checks, {} markers weighed by the head refit, {} fill terms, {} smoothed markers, {} retargeting ({} inverse-multiquadric kernels, {} multiply-adds)",
                    c.markers,
                    c.head_distance_checks,
                    c.rigid_fits,
                    c.head_markers,
                    c.horn_squarings,
                    c.step_checks,
                    c.refit_markers,
                    c.fill_terms,
                    c.smoothed_markers,
                    match st.retarget {
                        Retarget::Rbf(_) => "RBF",
                        Retarget::Proportional(_) => "proportional",
                    },
                    c.retarget_kernels,
                    c.retarget_multiply_adds
                ),
            }
        }),
    }
}

/// A linear rig's derived markers, described (none for other rigs).
fn derived_markers(rig: &Rig<'_>) -> Vec<String> {
    let Deformer::Linear(l) = rig.deformer() else {
        return Vec::new();
    };
    let names = marker_names(rig);
    let name = |m: u8| {
        let m = usize::from(m);
        names
            .get(m)
            .cloned()
            .unwrap_or_else(|| format!("marker {m}"))
    };
    l.derived()
        .map(|d| match d {
            DerivedMarker::Projection { source, direction } => {
                let one = f64::from(DIRECTION_ONE);
                let a = direction.map(|c| f64::from(c) / one);
                let length = a
                    .iter()
                    .map(|c| c * c)
                    .sum::<f64>()
                    .sqrt()
                    .max(f64::MIN_POSITIVE);
                format!(
                    "{} along [{:.2}, {:.2}, {:.2}]",
                    name(source),
                    a[0] / length,
                    a[1] / length,
                    a[2] / length
                )
            }
            DerivedMarker::Mean { sources, count } => {
                let n = usize::from(count).min(sources.len());
                let of: Vec<String> = sources[..n].iter().map(|&m| name(m)).collect();
                format!("mean of {}", of.join(", "))
            }
        })
        .collect()
}

/// Run `facebake inspect`.
pub fn run(args: &InspectArgs) -> Result<ExitCode, CliError> {
    let bytes = read_file(&args.rig)?;
    let rig = load_rig(&args.rig, &bytes)?;
    let s = summarise(args.rig.clone(), &bytes, &rig);
    if args.json {
        print_json(&s);
    } else {
        print_text(&s);
    }
    Ok(ExitCode::SUCCESS)
}

fn print_text(s: &InspectSummary) {
    let mut out = String::new();
    outln!(
        out,
        "{}: facebake rig, format version {}, {} deformer{}",
        s.rig.display(),
        s.format_version,
        s.deformer,
        match s.affine {
            Some(true) => " with affine rows",
            Some(false) => " without affine rows",
            None => "",
        }
    );
    outln!(
        out,
        "  formats       positions Q8.24 rig units, rest positions Q0.15, {} {} (F = {})",
        if s.affine.is_some() {
            "kernel values"
        } else {
            "weights"
        },
        s.weight_format,
        s.weight_frac_bits
    );
    outln!(
        out,
        "  space         one rig unit = {} asset units, centred at {:?}",
        s.space_half_extent,
        s.space_centre
    );
    outln!(
        out,
        "  counts        {} vertices, {} markers, at most {} influences a vertex (K), {} influences ({:.2} per vertex)",
        s.vertices,
        s.markers,
        s.k,
        s.influences,
        s.mean_influences_per_vertex
    );
    // Names come from the blob: escaped, so terminal escapes in them are shown, not obeyed.
    outln!(
        out,
        "  markers       {}",
        facebake::io::escape_control(&s.marker_names.join(" "))
    );
    let sec = &s.sections;
    outln!(
        out,
        "  blob          {}: {} bytes/influence, other {:.2} bytes/vertex",
        bytes_text(s.blob_bytes),
        s.bytes_per_influence,
        s.other_bytes_per_vertex
    );
    outln!(
        out,
        "                header {}, marker names {}, marker rest {}, vertex rest {}, normals {}, {}influences {}, other {}",
        sec.header,
        sec.marker_names,
        sec.marker_rest,
        sec.vertex_rest,
        sec.normals,
        if s.affine.is_some() {
            format!("coefficient shifts {}, coefficient map {}, ", sec.row_shifts, sec.matrix)
        } else if s.deformer == "planar" {
            format!(
                "control triangles {}, influence counts {}, ",
                sec.matrix, sec.influence_counts
            )
        } else {
            format!(
                "marker pairs {}, pair counts {}, ",
                sec.matrix, sec.influence_counts
            )
        },
        sec.influences,
        sec.other
    );
    if !s.derived.is_empty() {
        outln!(
            out,
            "  derived       {} markers after the {}: {}",
            s.derived.len(),
            s.markers,
            facebake::io::escape_control(&s.derived.join("; "))
        );
    }
    outln!(out, "  per frame     {}", s.cost.text);
    outln!(
        out,
        "  normals       {} (Rig::normals, when called); Rig::normals_planned: the same normals \
         over {} triangles, each taken once, with {} of caller scratch",
        s.cost.normals,
        s.normals_plan_triangles,
        bytes_text(s.normals_planned_scratch_bytes)
    );
    if let Some(c) = &s.capture {
        outln!(
            out,
            "  {}       head markers {}; actor half extent {:.1} mm; rejects displacements over {:.1} mm; stages {} bytes",
            if c.at_rest { "at rest" } else { "capture" },
            if c.head_markers.is_empty() { "none".to_string() } else { facebake::io::escape_control(&c.head_markers.join(", ")).into_owned() },
            c.actor_half_extent_m * 1000.0,
            c.max_displacement_m * 1000.0,
            sec.stages
        );
        outln!(
            out,
            "  checks        head-marker distances within {:.2} mm; steps over {:.2} mm per frame rejected; smoothing {}; head refit {}",
            c.head_tolerance_m * 1000.0,
            c.max_step_m * 1000.0,
            c.smoothing_lag_frames
                .map_or("off".to_string(), |l| format!("one-euro, lag when still {l} frames")),
            c.head_refit_m
                .map_or("off".to_string(), |m| format!("over the face, cutoff {:.2} mm", m * 1000.0))
        );
        outln!(out, "  per frame     + capture stages: {}", c.cost);
    }
    emit(&out);
}
