//! `facebake pack`: a capture compressed into a packed take (`.fbt`) that plays from flash.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::{emit, load_rig, parse_units, print_json, read_file, write_file, CliError};
use facebake::io::capture::read_capture_with_units;
use facebake::io::capture::take::{pack, PackOptions};
use facebake::model::Units;

/// Arguments of `facebake pack`.
#[derive(Debug, Args)]
pub struct PackArgs {
    /// The capture (.c3d, .trc, .csv, or a take to repack). Missing samples stay missing.
    #[arg(value_name = "CAPTURE")]
    pub capture: PathBuf,
    /// Where to write the packed take (.fbt).
    #[arg(short, long, value_name = "FBT")]
    pub output: PathBuf,
    /// The largest error of any decoded sample, millimetres.
    #[arg(long, value_name = "MM", default_value_t = 0.1)]
    pub max_error_mm: f64,
    /// Other bounds for named markers: NAME=MM, comma-separated.
    #[arg(long, value_name = "NAME=MM", value_delimiter = ',', value_parser = parse_marker_bound)]
    pub marker_max_error: Vec<(String, f64)>,
    /// Frames from one key frame to the next: the most a seek decodes.
    #[arg(long, value_name = "N", default_value_t = 128)]
    pub key_interval: u16,
    /// Predicted frames per block of residual widths (at most the key interval).
    #[arg(long, value_name = "B", default_value_t = 32)]
    pub block_frames: u16,
    /// Store the samples in this rig's actor space (a rig with capture stages, from a capture or
    /// at rest), so the runtime plays the decoded integers as they are (the firmware does).
    #[arg(long, value_name = "RIG")]
    pub rig: Option<PathBuf>,
    /// Units of the capture's numbers, overriding what the file says.
    #[arg(long, value_name = "UNITS", value_parser = parse_units)]
    pub capture_units: Option<Units>,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `NAME=MM`.
fn parse_marker_bound(s: &str) -> Result<(String, f64), String> {
    let (name, mm) = s
        .rsplit_once('=')
        .ok_or_else(|| format!("{s:?}: expected NAME=MM"))?;
    let mm: f64 = mm
        .trim()
        .parse()
        .map_err(|_| format!("{s:?}: {mm:?} is not a number of millimetres"))?;
    Ok((name.trim().to_string(), mm))
}

/// What `pack` reports.
#[derive(Debug, Serialize)]
pub struct PackSummary {
    /// The capture.
    pub capture: PathBuf,
    /// The take written.
    pub output: PathBuf,
    /// Frames.
    pub frames: usize,
    /// Markers.
    pub markers: usize,
    /// Samples missing (kept missing).
    pub missing_samples: usize,
    /// Frames per second.
    pub rate_hz: f64,
    /// The capture's units.
    pub units: String,
    /// Raw size: frames × markers × 3 × 4 bytes.
    pub raw_bytes: usize,
    /// The take's size.
    pub packed_bytes: usize,
    /// Raw / packed.
    pub ratio: f64,
    /// The bound asked for, mm.
    pub max_error_mm: f64,
    /// The largest error measured by decoding, mm.
    pub measured_max_error_mm: f64,
    /// Key interval.
    pub key_interval: u16,
    /// Block length.
    pub block_frames: u16,
    /// The rig whose actor space the samples are in, if any.
    pub rig: Option<PathBuf>,
}

/// Run `facebake pack`.
pub fn run(args: &PackArgs) -> Result<ExitCode, CliError> {
    let capture = read_capture_with_units(&args.capture, args.capture_units)?;
    for (name, _) in &args.marker_max_error {
        if capture.marker_index(name).is_none() {
            return Err(CliError::input(
                &args.capture,
                format!(
                    "--marker-max-error names \"{}\", which the capture does not have",
                    facebake::io::escape_control(name)
                ),
            ));
        }
    }
    let space = match &args.rig {
        Some(path) => {
            let bytes = read_file(path)?;
            let rig = load_rig(path, &bytes)?;
            Some(rig.actor_space().ok_or_else(|| {
                CliError::input(
                    path,
                    "the rig has no capture stages (its bake said why) and so no actor space",
                )
            })?)
        }
        None => None,
    };
    let options = PackOptions {
        max_error_mm: args.max_error_mm,
        marker_max_error_mm: args.marker_max_error.clone(),
        key_interval: args.key_interval,
        block_frames: args.block_frames,
        space,
    };
    let packed = pack(&capture, &options)?;
    write_file(&args.output, &packed.bytes)?;
    let summary = PackSummary {
        capture: args.capture.clone(),
        output: args.output.clone(),
        frames: packed.frames,
        markers: packed.markers,
        missing_samples: packed.missing,
        rate_hz: capture.rate_hz,
        units: capture.units.to_string(),
        raw_bytes: packed.raw_bytes,
        packed_bytes: packed.bytes.len(),
        ratio: packed.ratio(),
        max_error_mm: args.max_error_mm,
        measured_max_error_mm: packed.max_error_mm,
        key_interval: args.key_interval,
        block_frames: args.block_frames,
        rig: args.rig.clone(),
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut out = String::new();
        outln!(
            out,
            "packed {} frames × {} markers ({} Hz, {}, {} samples missing) into {}",
            summary.frames,
            summary.markers,
            summary.rate_hz,
            summary.units,
            summary.missing_samples,
            summary.output.display()
        );
        outln!(
            out,
            "{} bytes, {:.1}× smaller than raw 32-bit markers ({} bytes); largest error {:.4} mm (bound {} mm)",
            summary.packed_bytes,
            summary.ratio,
            summary.raw_bytes,
            summary.measured_max_error_mm,
            summary.max_error_mm
        );
        outln!(
            out,
            "key frame every {} frames, residual widths every {}{}",
            summary.key_interval,
            summary.block_frames,
            match &summary.rig {
                Some(r) => format!("; samples in the actor space of {}", r.display()),
                None => String::new(),
            }
        );
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}
