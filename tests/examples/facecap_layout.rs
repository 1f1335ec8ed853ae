//! Writes `fixtures/facecap_jawmocap_layout.toml`: JawMoCap's 41 markers placed on the FaceCap
//! head as `facebake place` places them, from seven landmarks found from the mesh's openings
//! and nose, then the lip and eyelid markers onto the lips and lids (see `facebake::placement`). The
//! test `placement::tests` checks the committed file against a fresh placement. The file ends
//! with the lip and eyelid marker groups of the surface-aware masks.
//! `cargo run -p facebake-tests --example facecap_layout`
use facebake::io::capture::read_capture;
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::write_layout;
use facebake::placement::place;
use facebake_tests::fixture;

/// Which of JawMoCap's markers sit above and below the mouth and the eyes: the lip and eyelid
/// markers, as `bake --masks` finds them from the openings when a layout has no groups. (The
/// chin's markers in the lower lip's group held planar bones' lips to the chin: on JawMoCap 109
/// frames stretched an edge over 2×, none without them.)
const GROUPS: &str = "
[groups]
mouth = { upper = [\"Mouth_Up\", \"Mouth_UpL1\", \"Mouth_UpR1\"], lower = [\"Mouth_Down\", \"Mouth_DownL\", \"Mouth_DownR\"] }
eyes = { upper = [\"Leye_Up\", \"Reye_Up\"], lower = [\"Leye_Down\", \"Reye_Down\"] }
";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None)?;
    let cap = read_capture(&fixture("JawMoCap.trc"))?;
    let neutral: Vec<[f64; 3]> = cap.frames[0]
        .iter()
        .map(|p| p.ok_or("frame 0 has a missing marker"))
        .collect::<Result<_, _>>()?;
    let layout = place(&mesh, &cap.marker_names, &neutral, &[])?;
    let out = fixture("facecap_jawmocap_layout.toml");
    write_layout(&out, &layout)?;
    // The discontinuity masks' marker groups (`facebake bake --masks`).
    let mut text = std::fs::read_to_string(&out)?;
    text.push_str(GROUPS);
    std::fs::write(&out, text)?;
    println!("wrote {} ({} markers)", out.display(), layout.markers.len());
    Ok(())
}
