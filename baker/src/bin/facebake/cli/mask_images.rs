//! `facebake mask-images`: the automatic sides of every mask of a layout, rendered as grey PNGs
//! in the mesh's cylindrical projection (paper 000 §4.3), to inspect or to paint over and give
//! back to `bake --masks --mask-image NAME=FILE`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::{emit, print_json, CliError};
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::read_layout;
use facebake::io::mask_image::write_sides;
use facebake::model::DEFAULT_MAX_SNAP_FRACTION;
use facebake::model::{place_markers, Side};
use facebake::surface::SideRule;
use facebake::surface::{mask_sides, SurfaceInput, SurfaceMarker};
use facebake::SurfaceOptions;

/// Arguments of `facebake mask-images`.
#[derive(Debug, Args)]
pub struct MaskImagesArgs {
    /// The face mesh (.glb or .gltf).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Which mesh of the file (default: the face's, the largest primitive of any mesh with a
    /// mouth and two eyes; else the first).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Which primitive of the mesh (default: the face, the largest with a mouth and two eyes;
    /// else the first triangle primitive).
    #[arg(long, value_name = "INDEX")]
    pub primitive: Option<usize>,
    /// The marker layout with a `[groups]` table (one mask per group).
    #[arg(long, value_name = "LAYOUT")]
    pub layout: PathBuf,
    /// Folder for the images, one `<mask>.png` each.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Image width and height in pixels (FaceCap's touching lips need 4096 to keep the lip rims
    /// apart: 0.06 mm per pixel).
    #[arg(long, value_name = "PIXELS", default_value_t = 4096, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub size: u32,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// One image written.
#[derive(Debug, Serialize)]
pub struct MaskImage {
    /// The mask (group) name.
    pub mask: String,
    /// The file.
    pub path: PathBuf,
    /// Vertices on the upper side at strength ≥ ½.
    pub upper_vertices: usize,
    /// Vertices on the lower side at strength ≥ ½.
    pub lower_vertices: usize,
}

/// Run `facebake mask-images`.
pub fn run(args: &MaskImagesArgs) -> Result<ExitCode, CliError> {
    let mesh = load_mesh(&args.mesh, args.mesh_name.as_deref(), args.primitive)?;
    let layout = read_layout(&args.layout)?;
    let placed = place_markers(&layout, &mesh, DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal())?;
    let groups = &layout.groups;
    if groups.is_empty() {
        return Err(CliError::input(
            &args.layout,
            "no [groups] table: nothing to render (name the upper and lower markers of each opening)",
        ));
    }
    let markers: Vec<SurfaceMarker> = placed.iter().map(SurfaceMarker::from_placed).collect();
    let sides = mask_sides(
        &SurfaceInput {
            mesh: &mesh,
            markers: &markers,
            groups,
            sides: &SideRule::Auto,
            head_fit: false,
            held: None,
        },
        &SurfaceOptions::default(),
    )
    .map_err(|e| CliError::input(&args.layout, format!("mask sides: {e}")))?;
    std::fs::create_dir_all(&args.output).map_err(|e| CliError::io(&args.output, e))?;
    let size = args.size as usize;
    let mut written = Vec::new();
    for m in &sides {
        let path = args.output.join(format!("{}.png", m.groups.name));
        write_sides(
            &path,
            &mesh.positions,
            &mesh.triangles,
            &m.side,
            &m.strength,
            size,
            size,
        )
        .map_err(|e| CliError::input(&path, e.to_string()))?;
        let count = |want: Side| {
            m.side
                .iter()
                .zip(&m.strength)
                .filter(|(s, w)| **s == Some(want) && **w >= 0.5)
                .count()
        };
        written.push(MaskImage {
            mask: m.groups.name.clone(),
            path,
            upper_vertices: count(Side::Upper),
            lower_vertices: count(Side::Lower),
        });
    }
    if args.json {
        print_json(&written);
    } else {
        let mut out = String::new();
        for w in &written {
            outln!(
                out,
                "mask \"{}\": {} upper and {} lower vertices → {}",
                w.mask,
                w.upper_vertices,
                w.lower_vertices,
                w.path.display()
            );
        }
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}
