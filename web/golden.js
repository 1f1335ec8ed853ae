// The golden check in the browser: every bundled golden rig, input and packed take played
// through the wasm runtime, each frame hashed as fixtures/golden/hashes.txt, hashes_planar.txt,
// hashes_normals.txt and hashes_take.txt record it (as ffi/examples/c/play_golden.c does natively). The lines are
// printed in that program's format, so web/test/browser-test.mjs compares them with the files
// exactly as .ci/ffi.sh does.

import { Fnv1a64 } from './facebake.js';

/** The deform rigs with their names in the hash files and the marker frames each plays. */
const DEFORM_RIGS = [
  ['coefficients', 'facecap_coefficients.fbk', 'facecap_markers.bin'],
  ['weights', 'facecap_weights.fbk', 'facecap_markers.bin'],
  ['coefficients_k4', 'facecap_coefficients_k4.fbk', 'facecap_markers.bin'],
  ['product', 'facecap_product.fbk', 'facecap_layout_markers.bin'],
  ['planar', 'facecap_planar.fbk', 'facecap_markers.bin'],
];

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) {
    throw new Error(`${url}: HTTP ${r.status}`);
  }
  return new Uint8Array(await r.arrayBuffer());
}

/** Frame `f`'s normals of the rig's current output: printed, and fed to `sequence`. */
function normalsLine(rig, name, f, sequence, lines, timing) {
  const t0 = performance.now();
  rig.normals();
  timing.normalsMs += performance.now() - t0;
  const h = new Fnv1a64();
  h.write(rig.normalsView());
  sequence.write(rig.normalsView());
  lines.push(`normals ${name} frame ${f} ${h.hex()}`);
}

/** Every frame of a marker file (frames × markers × 3 i32 LE) through `fb_deform`. */
function deformTake(runtime, name, blob, markers, lines) {
  const rig = runtime.loadRig(blob);
  const frameBytes = rig.markerCount * 12;
  const words = new DataView(markers.buffer, markers.byteOffset, markers.byteLength);
  const sequence = new Fnv1a64();
  const normalsSequence = new Fnv1a64();
  const timing = { ms: 0, normalsMs: 0 };
  let frames = 0;
  for (let f = 0; (f + 1) * frameBytes <= markers.length; f++) {
    const input = rig.markerView();
    for (let i = 0; i < 3 * rig.markerCount; i++) {
      input[i] = words.getInt32(f * frameBytes + 4 * i, true);
    }
    const t0 = performance.now();
    rig.deform();
    timing.ms += performance.now() - t0;
    frames++;
    const h = new Fnv1a64();
    h.write(rig.outView());
    sequence.write(rig.outView());
    lines.push(`${name} frame ${f} ${h.hex()}`);
    normalsLine(rig, name, f, normalsSequence, lines, timing);
  }
  lines.push(`${name} sequence ${sequence.hex()}`);
  lines.push(`normals ${name} sequence ${normalsSequence.hex()}`);
  return { rig: name, frames, msPerFrame: timing.ms / frames, normalsMsPerFrame: timing.normalsMs / frames };
}

/** Every frame of jawmocap_actor.bin through `fb_play`, one play state (one character). */
function playTake(runtime, blob, take, lines) {
  const rig = runtime.loadRig(blob);
  const record = 1 + 12; // present byte, x y z
  const frameBytes = rig.markerCount * record;
  const words = new DataView(take.buffer, take.byteOffset, take.byteLength);
  const sequence = new Fnv1a64();
  const normalsSequence = new Fnv1a64();
  const tail = new Int32Array(3);
  const timing = { ms: 0, normalsMs: 0 };
  let frames = 0;
  for (let f = 0; (f + 1) * frameBytes <= take.length; f++) {
    const actor = rig.actorView();
    const present = rig.presentView();
    for (let j = 0; j < rig.markerCount; j++) {
      const at = f * frameBytes + j * record;
      present[j] = take[at];
      for (let c = 0; c < 3; c++) {
        actor[3 * j + c] = words.getInt32(at + 1 + 4 * c, true);
      }
    }
    const t0 = performance.now();
    const report = rig.play();
    timing.ms += performance.now() - t0;
    frames++;
    tail[0] = report.rigidResidual;
    tail[1] = report.rebuiltCount;
    tail[2] = report.heldCount;
    const h = new Fnv1a64();
    for (const hash of [h, sequence]) {
      hash.write(rig.characterView());
      hash.write(rig.outView());
      hash.write(tail);
    }
    lines.push(`capture frame ${f} ${h.hex()}`);
    normalsLine(rig, 'capture', f, normalsSequence, lines, timing);
  }
  lines.push(`capture sequence ${sequence.hex()}`);
  lines.push(`normals capture sequence ${normalsSequence.hex()}`);
  return { rig: 'capture', frames, msPerFrame: timing.ms / frames, normalsMsPerFrame: timing.normalsMs / frames };
}

/**
 * The packed take jawmocap.fbt, decoded by `fb_take_next_frame` and played through the capture
 * rig, hashed as hashes_take.txt records it: the samples (presence byte, x y z), the character
 * markers, the vertices and (head residual, rebuilt, held).
 */
function playPackedTake(runtime, blob, bytes, lines) {
  const rig = runtime.loadRig(blob);
  const take = runtime.loadTake(bytes);
  const map = rig.markerNames.map((name) => take.markerNames.indexOf(name));
  const sequence = new Fnv1a64();
  const sample = new Uint8Array(13);
  const sampleWords = new DataView(sample.buffer);
  const tail = new Int32Array(3);
  const timing = { ms: 0, decodeMs: 0 };
  let f;
  for (;;) {
    let t0 = performance.now();
    f = take.next();
    timing.decodeMs += performance.now() - t0;
    if (f < 0) {
      break;
    }
    const samples = take.samplesView();
    const present = take.presentView();
    const actor = rig.actorView();
    const given = rig.presentView();
    const h = new Fnv1a64();
    map.forEach((k, j) => {
      const here = k >= 0 && present[k] === 1;
      given[j] = here ? 1 : 0;
      sample[0] = given[j];
      for (let c = 0; c < 3; c++) {
        actor[3 * j + c] = here ? samples[3 * k + c] : 0;
        sampleWords.setInt32(1 + 4 * c, actor[3 * j + c], true);
      }
      h.write(sample);
      sequence.write(sample);
    });
    t0 = performance.now();
    const report = rig.play();
    timing.ms += performance.now() - t0;
    tail[0] = report.rigidResidual;
    tail[1] = report.rebuiltCount;
    tail[2] = report.heldCount;
    for (const hash of [h, sequence]) {
      hash.write(rig.characterView());
      hash.write(rig.outView());
      hash.write(tail);
    }
    lines.push(`take frame ${f} ${h.hex()}`);
  }
  lines.push(`take sequence ${sequence.hex()}`);
  return { rig: 'take', frames: take.frameCount, msPerFrame: timing.ms / take.frameCount, decodeMsPerFrame: timing.decodeMs / take.frameCount };
}

/**
 * Play every golden rig from `dir` (a URL prefix ending in '/') through `runtime`; returns the
 * hash lines and per rig the mean time of a frame's deform or play call and of its normals.
 */
export async function goldenHashes(runtime, dir) {
  const lines = [];
  const timing = [];
  for (const [name, file, frames] of DEFORM_RIGS) {
    const markers = await fetchBytes(dir + frames);
    timing.push(deformTake(runtime, name, await fetchBytes(dir + file), markers, lines));
  }
  const capture = await fetchBytes(dir + 'jawmocap_capture.fbk');
  timing.push(playTake(runtime, capture, await fetchBytes(dir + 'jawmocap_actor.bin'), lines));
  timing.push(playPackedTake(runtime, capture, await fetchBytes(dir + 'jawmocap.fbt'), lines));
  return { lines, timing };
}
