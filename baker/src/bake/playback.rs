//! A capture played through rigs just baked, frame by frame, as the runtime plays it: what the
//! bake's choices made on the capture ([`super::mouth_share`], [`super::relax`]) judge.

use facebake_runtime::{PlayState, Rig};

use super::BakeError;
use crate::model::Capture;

/// Play every frame of `capture` through each rig of `blobs` side by side and hand `each` every
/// rig's vertices (asset units, glTF order). Nothing per frame is kept.
pub(crate) fn play(
    blobs: &[&[u8]],
    capture: &Capture,
    mut each: impl FnMut(&[Vec<[f64; 3]>]),
) -> Result<(), BakeError> {
    let rigs = blobs
        .iter()
        .map(|b| {
            Rig::from_bytes(b)
                .map_err(|e| BakeError::Input(format!("the rig just baked does not load: {e}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let Some(first) = rigs.first() else {
        return Ok(());
    };
    let metres = capture.in_metres();
    let columns: Vec<Option<usize>> = first
        .marker_names()
        .map(|n| metres.marker_index(n))
        .collect();
    let actor_space = first
        .actor_space()
        .ok_or_else(|| BakeError::Input("the rig just baked has no capture stages".into()))?;
    let mut states: Vec<PlayState> = rigs.iter().map(|_| PlayState::new()).collect();
    let mut out: Vec<Vec<[i32; 3]>> = rigs
        .iter()
        .map(|r| vec![[0; 3]; r.vertex_count()])
        .collect();
    let mut vertices: Vec<Vec<[f64; 3]>> = rigs
        .iter()
        .map(|r| vec![[0.0; 3]; r.vertex_count()])
        .collect();
    for (f, frame) in metres.frames.iter().enumerate() {
        let actor: Vec<Option<[i32; 3]>> = columns
            .iter()
            .map(|c| {
                c.and_then(|c| frame[c])
                    .and_then(|p| actor_space.to_rig_f64(p).ok())
            })
            .collect();
        for (((rig, state), out), vertices) in rigs
            .iter()
            .zip(&mut states)
            .zip(&mut out)
            .zip(&mut vertices)
        {
            rig.play(state, &actor, out).map_err(|e| {
                BakeError::Input(format!("{}: frame {f}: {e}", capture.source.display()))
            })?;
            let space = rig.space();
            for (v, q) in vertices.iter_mut().zip(out.iter()) {
                *v = space.to_asset_f64(*q);
            }
        }
        each(&vertices);
    }
    Ok(())
}
