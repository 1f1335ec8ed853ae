// The facebake viewer: a glTF head deformed live by the wasm runtime from a marker take.
//
// Query parameters (URLs relative to this page; defaults: the bundled fixtures):
//   mesh  the character's glTF binary       ../fixtures/FaceCapHeadGeneric.glb
//   rig   a rig baked with --capture         ../fixtures/golden/jawmocap_capture.fbk
//   take  the actor's capture: TRC, CSV or   ../fixtures/JawMoCap.trc
//         a packed take (.fbt)
//   wasm  facebake-ffi built for wasm32      build/facebake_ffi.wasm (.ci/browser.sh puts it there)
//   frame the frame shown first (paused)
//   test  golden: also play every golden rig and expose the hash lines as window.golden
//
// The take's markers are matched to the rig's by name, converted to metres as the baker does
// and to the rig's actor space (Q8.24) as `Space::to_rig_f64` does, so the integers fed to
// `fb_play` are those `facebake play` feeds the native runtime. Every frame is played in order
// from the first (the stages filter over time), so a seek replays from frame 0.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { NORMAL_ONE, Runtime, toAsset, toRig } from './facebake.js';
import { parseCapture } from './capture.js';

const params = new URLSearchParams(location.search);
const urls = {
  mesh: params.get('mesh') ?? '../fixtures/FaceCapHeadGeneric.glb',
  rig: params.get('rig') ?? '../fixtures/golden/jawmocap_capture.fbk',
  take: params.get('take') ?? '../fixtures/JawMoCap.trc',
  wasm: params.get('wasm') ?? 'build/facebake_ffi.wasm',
};
const ui = {
  status: document.getElementById('status'),
  play: document.getElementById('play'),
  slider: document.getElementById('frame'),
  label: document.getElementById('label'),
  stats: document.getElementById('stats'),
  view: document.getElementById('view'),
};

function say(text) {
  ui.status.textContent = text;
}

async function fetchOk(url) {
  const r = await fetch(url);
  if (!r.ok) {
    throw new Error(`${url}: HTTP ${r.status}`);
  }
  return r;
}

/**
 * A packed take as a capture ({ rate, names, frames }), decoded by the runtime. Packed with
 * `--rig` for this rig (its space is the rig's actor space), the samples are kept as they are,
 * Q8.24 actor units (`actorUnits`), as `fb_play` takes them; otherwise converted to metres.
 */
function decodePackedTake(runtime, bytes, actorSpace) {
  const take = runtime.loadTake(bytes);
  const s = take.space;
  const actorUnits = s.halfExtent === actorSpace.halfExtent && s.centre.every((c, i) => c === actorSpace.centre[i]);
  const frames = [];
  while (take.next() >= 0) {
    const samples = take.samplesView();
    const present = take.presentView();
    frames.push(
      take.markerNames.map((_, k) => {
        if (present[k] !== 1) {
          return null;
        }
        const q = Array.from(samples.subarray(3 * k, 3 * k + 3));
        if (!actorUnits) {
          toAsset(s, q, q);
        }
        return q;
      }),
    );
  }
  return { rate: take.rate, names: take.markerNames, frames, actorUnits };
}

/** The take as rig input: per frame, Q8.24 actor units and presence, in the rig's marker order. */
function actorFrames(rig, take) {
  const m = rig.markerCount;
  const index = rig.markerNames.map((name) => take.names.indexOf(name));
  const unmatched = rig.markerNames.filter((_, j) => index[j] < 0);
  const actor = new Int32Array(take.frames.length * m * 3);
  const present = new Uint8Array(take.frames.length * m);
  take.frames.forEach((frame, f) => {
    for (let j = 0; j < m; j++) {
      const p = index[j] < 0 ? null : frame[index[j]];
      const q = p && (take.actorUnits ? p : toRig(rig.actorSpace, p));
      if (q) {
        actor.set(q, (f * m + j) * 3);
        present[f * m + j] = 1;
      }
    }
  });
  return { actor, present, count: take.frames.length, rate: take.rate, unmatched };
}

/** The scene: the glTF with the rig's mesh given dynamic positions and normals, marker dots. */
function buildScene(gltf, rig) {
  let head = null;
  gltf.scene.traverse((o) => {
    if (o.isMesh && o.geometry.attributes.position.count === rig.vertexCount) {
      head = o;
    }
  });
  if (!head) {
    throw new Error(`the glTF has no mesh of ${rig.vertexCount} vertices (the rig's)`);
  }
  // The rig's vertices are the primitive's, in glTF vertex order: check against its rest pose.
  const gltfRest = head.geometry.attributes.position;
  const rest = rig.vertexRest();
  let restError = 0;
  for (let i = 0; i < rest.length; i++) {
    restError = Math.max(restError, Math.abs(rest[i] - gltfRest.array[i]));
  }
  const box = new THREE.Box3().setFromBufferAttribute(gltfRest);
  if (restError > 1e-3 * box.getSize(new THREE.Vector3()).length()) {
    throw new Error(`the rig's rest vertices are ${restError} from the glTF mesh's: another mesh?`);
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setIndex(head.geometry.index);
  const position = new THREE.BufferAttribute(new Float32Array(3 * rig.vertexCount), 3);
  const normal = new THREE.BufferAttribute(new Float32Array(3 * rig.vertexCount), 3);
  position.setUsage(THREE.DynamicDrawUsage);
  normal.setUsage(THREE.DynamicDrawUsage);
  geometry.setAttribute('position', position);
  geometry.setAttribute('normal', normal);
  head.geometry = geometry; // no morph targets: the runtime moves the vertices
  head.morphTargetInfluences = undefined;
  head.morphTargetDictionary = undefined;
  head.frustumCulled = false;
  gltf.scene.traverse((o) => {
    if (o.isMesh) {
      const skin = o === head;
      o.material = new THREE.MeshStandardMaterial({
        color: skin ? 0xd9a58c : 0xf2efe6, // the eyes sit at the origin, inside the skull
        roughness: skin ? 0.55 : 0.3,
      });
    }
  });
  const dots = new THREE.BufferGeometry();
  dots.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * rig.markerCount), 3));
  const markers = new THREE.Points(
    dots,
    new THREE.PointsMaterial({ color: 0x1e90ff, size: 0.005, depthTest: false }),
  );
  markers.frustumCulled = false;
  markers.renderOrder = 1;
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x20242b);
  scene.add(gltf.scene, markers);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.2));
  const key = new THREE.DirectionalLight(0xffffff, 2.0);
  key.position.set(0.4, 0.5, 1.0);
  scene.add(key);
  return { scene, head, markers, box };
}

/** The renderer, or null where WebGL is unavailable (the runtime still plays). */
function makeRenderer() {
  try {
    const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio);
    ui.view.appendChild(renderer.domElement);
    return renderer;
  } catch (e) {
    return null;
  }
}

async function main() {
  say('loading…');
  const [runtime, blob, takeBytes, gltf] = await Promise.all([
    Runtime.load(urls.wasm),
    fetchOk(urls.rig).then((r) => r.arrayBuffer()),
    fetchOk(urls.take).then((r) => r.arrayBuffer()),
    new GLTFLoader().loadAsync(urls.mesh),
  ]);
  const rig = runtime.loadRig(blob);
  if (!rig.hasStages) {
    throw new Error(`${urls.rig} has no capture stages: bake it with --capture`);
  }
  const packed = new TextDecoder().decode(new Uint8Array(takeBytes, 0, Math.min(8, takeBytes.byteLength))) === 'FACETAKE';
  const take = actorFrames(
    rig,
    packed ? decodePackedTake(runtime, takeBytes, rig.actorSpace) : parseCapture(new TextDecoder().decode(takeBytes)),
  );
  const { scene, head, markers, box } = buildScene(gltf, rig);

  const renderer = makeRenderer();
  const camera = new THREE.PerspectiveCamera(30, 1, 0.01, 10);
  const centre = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length();
  camera.position.set(centre.x + 0.35 * size, centre.y + 0.1 * size, centre.z + 1.5 * size);
  const controls = renderer && new OrbitControls(camera, renderer.domElement);
  if (controls) {
    controls.target.copy(centre);
    controls.update();
  } else {
    camera.lookAt(centre);
  }
  function resize() {
    const w = ui.view.clientWidth;
    const h = ui.view.clientHeight;
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    renderer?.setSize(w, h);
  }
  window.addEventListener('resize', resize);
  resize();

  ui.slider.max = String(take.count - 1);
  const m = rig.markerCount;
  let next = 0; // the frame the play state expects next
  let shown = -1;
  let playing = false;
  let clock = { start: 0, frame: 0 }; // playing: frame `frame` was due at time `start`
  const cost = { frames: 0, playMs: 0, normalFrames: 0, normalsMs: 0 };

  /** Play frame `f` through the runtime (input copied from the precomputed take). */
  function playFrame(f) {
    rig.actorView().set(take.actor.subarray(f * m * 3, (f + 1) * m * 3));
    rig.presentView().set(take.present.subarray(f * m, (f + 1) * m));
    const t0 = performance.now();
    const report = rig.play();
    cost.playMs += performance.now() - t0;
    cost.frames++;
    next = f + 1;
    return report;
  }

  /** Advance the runtime to frame `f` (replaying from 0 if it is behind) and draw it. */
  function showFrame(f) {
    f = Math.max(0, Math.min(take.count - 1, f));
    if (f < next - 1) {
      rig.resetState();
      next = 0;
    }
    let report = null;
    while (next <= f) {
      report = playFrame(next);
    }
    if (report) {
      const t0 = performance.now();
      rig.normals();
      cost.normalsMs += performance.now() - t0;
      cost.normalFrames++;
      toAsset(rig.space, rig.outView(), head.geometry.attributes.position.array);
      const n = rig.normalsView();
      const normals = head.geometry.attributes.normal.array;
      for (let i = 0; i < n.length; i++) {
        normals[i] = n[i] / NORMAL_ONE;
      }
      toAsset(rig.space, rig.characterView(), markers.geometry.attributes.position.array);
      head.geometry.attributes.position.needsUpdate = true;
      head.geometry.attributes.normal.needsUpdate = true;
      markers.geometry.attributes.position.needsUpdate = true;
      ui.stats.textContent =
        `rebuilt ${report.rebuiltCount}, held ${report.heldCount} · ` +
        `fb_play ${(cost.playMs / cost.frames).toFixed(3)} ms, ` +
        `fb_normals_planned ${(cost.normalsMs / cost.normalFrames).toFixed(3)} ms a frame`;
    }
    shown = f;
    ui.slider.value = String(f);
    ui.label.textContent = `frame ${f + 1} / ${take.count} · ${(f / take.rate).toFixed(2)} s at ${take.rate} Hz`;
    renderer?.render(scene, camera);
  }

  function setPlaying(on) {
    playing = on;
    ui.play.textContent = on ? 'pause' : 'play';
    clock = { start: performance.now(), frame: shown >= take.count - 1 ? 0 : shown + 1 };
  }
  ui.play.addEventListener('click', () => setPlaying(!playing));
  ui.slider.addEventListener('input', () => {
    setPlaying(false);
    showFrame(Number(ui.slider.value));
  });
  controls?.addEventListener('change', () => renderer.render(scene, camera));

  function tick(now) {
    if (playing) {
      let f = clock.frame + Math.floor(((now - clock.start) / 1000) * take.rate);
      if (f >= take.count) {
        clock = { start: now, frame: 0 };
        f = 0;
      }
      if (f !== shown) {
        showFrame(f);
      }
    }
    requestAnimationFrame(tick);
  }

  const first = Number(params.get('frame') ?? 0);
  showFrame(first);
  say(
    `${rig.vertexCount} vertices, ${m} markers, ${take.count} frames at ${take.rate} Hz` +
      (take.unmatched.length ? ` · not in the take: ${take.unmatched.join(', ')}` : '') +
      (renderer ? '' : ' · WebGL unavailable: playing without drawing'),
  );
  if (!params.has('frame') && !params.has('test')) {
    setPlaying(true);
  }
  requestAnimationFrame(tick);

  // For the browser test: drive frames and read what was played.
  window.viewer = {
    frames: take.count,
    webgl: renderer !== null,
    showFrame,
    cost: () => ({ ...cost }),
    actorFrame: (f) => ({
      actor: Array.from(take.actor.subarray(f * m * 3, (f + 1) * m * 3)),
      present: Array.from(take.present.subarray(f * m, (f + 1) * m)),
    }),
  };
}

async function golden() {
  const { goldenHashes } = await import('./golden.js');
  const runtime = await Runtime.load(urls.wasm);
  return goldenHashes(runtime, '../fixtures/golden/');
}

main()
  .catch((e) => {
    say(`error: ${e.message}`);
    window.viewerError = e.message;
  })
  .finally(async () => {
    if (params.get('test') === 'golden') {
      window.golden = await golden().catch((e) => ({ error: e.message }));
    }
  });
