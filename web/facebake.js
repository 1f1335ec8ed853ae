// The facebake runtime in a browser: the C ABI (crate facebake-ffi, built without `std` for
// wasm32-unknown-unknown) called from JavaScript over the module's linear memory.
//
// The module has no imports and no allocator: as in C, the caller provides every byte. Rust
// uses the memory below `__heap_base` (stack and statics) and never touches what lies above, so
// this wrapper reserves its buffers there, bump by bump, growing the memory by whole pages
// (`Arena`). Every buffer is reserved once, when a rig is loaded; nothing is freed.
//
// Integer calls (`deform`, `play`, `normals`, and a packed take's `next`) are the bit-identical
// ones the golden hashes are made of; `toAsset` converts their Q8.24 output to the asset's units
// for a renderer.

/** Q8.24: 1.0 = 2^24. */
export const POS_ONE = 1 << 24;
/** Q1.14 unit normals: 1.0 = 2^14. */
export const NORMAL_ONE = 1 << 14;
/** `sizeof(FbFrameReport)` on wasm32: seven 32-bit fields and three bitsets of 8 words. */
const REPORT_BYTES = 4 * (7 + 3 * 8);
/** `sizeof(FbSpace)`: centre[3] and half_extent, `float`. */
const SPACE_BYTES = 16;
const PAGE = 65536;
/** `FB_ERROR_END_OF_TAKE`. */
const END_OF_TAKE = 24;

/** A failed call: `code` is the `FbError`, the message is `fb_error_message`'s. */
export class FacebakeError extends Error {
  constructor(what, code, message) {
    super(`${what}: ${message} (FbError ${code})`);
    this.code = code;
  }
}

/** A bump region of linear memory above `__heap_base`, growing the memory as needed. */
class Arena {
  constructor(memory, base) {
    this.memory = memory;
    this.top = base;
  }

  /** `bytes` bytes aligned to `align` (a power of two); returns their address. */
  reserve(bytes, align = 8) {
    const at = (this.top + align - 1) & ~(align - 1);
    const end = at + bytes;
    const have = this.memory.buffer.byteLength;
    if (end > have) {
      this.memory.grow(Math.ceil((end - have) / PAGE));
    }
    this.top = end;
    return at;
  }
}

/** The loaded WebAssembly module: the `fb_*` functions and the arena. */
export class Runtime {
  /** Fetch and instantiate `url` (the facebake_ffi.wasm build). */
  static async load(url) {
    const response = await fetch(url);
    if (!response.ok) {
      throw new Error(`${url}: HTTP ${response.status}`);
    }
    const { instance } = await WebAssembly.instantiate(await response.arrayBuffer(), {});
    return new Runtime(instance);
  }

  constructor(instance) {
    this.fb = instance.exports;
    this.memory = this.fb.memory;
    this.arena = new Arena(this.memory, this.fb.__heap_base.value);
    // Out-parameters of the queries: a pointer and a length, or an FbSpace.
    this.scratch = this.arena.reserve(SPACE_BYTES, 8);
  }

  /** Views of the memory (made afresh: growing the memory detaches the old buffer). */
  bytes(ptr, n) {
    return new Uint8Array(this.memory.buffer, ptr, n);
  }
  i32(ptr, n) {
    return new Int32Array(this.memory.buffer, ptr, n);
  }
  i16(ptr, n) {
    return new Int16Array(this.memory.buffer, ptr, n);
  }
  f32(ptr, n) {
    return new Float32Array(this.memory.buffer, ptr, n);
  }
  u32(ptr, n) {
    return new Uint32Array(this.memory.buffer, ptr, n);
  }

  /** Throw a FacebakeError unless `code` is FB_ERROR_NONE. */
  check(code, what) {
    if (code !== 0) {
      const at = this.fb.fb_error_message(code);
      const b = new Uint8Array(this.memory.buffer, at);
      const message = new TextDecoder().decode(b.subarray(0, b.indexOf(0)));
      throw new FacebakeError(what, code, message);
    }
  }

  /** Copy a rig blob into the memory and load it (the rig borrows the copy for good). */
  loadRig(blob) {
    return new LoadedRig(this, new Uint8Array(blob));
  }

  /** Copy a packed take (.fbt) into the memory and load it with its reader. */
  loadTake(bytes) {
    return new LoadedTake(this, new Uint8Array(bytes));
  }

  /** Copy `bytes` into the arena; returns their address. */
  copyIn(bytes) {
    const at = this.arena.reserve(bytes.length, 8);
    this.bytes(at, bytes.length).set(bytes);
    return at;
  }

  /** The `count` marker names of a rig or take, through `fb_marker_name` or `fb_take_marker_name`. */
  names(call, ptr, count, what) {
    const out = [];
    for (let j = 0; j < count; j++) {
      this.check(call(ptr, j, this.scratch, this.scratch + 4), what);
      const [at, len] = this.u32(this.scratch, 2);
      out.push(new TextDecoder().decode(this.bytes(at, len).slice()));
    }
    return out;
  }

  /** An FbSpace through `call(ptr, out)` (`fb_rig_space`, `fb_rig_actor_space`, `fb_take_space`). */
  space(call, ptr, what) {
    this.check(call(ptr, this.scratch), what);
    const s = this.f32(this.scratch, 4);
    return { centre: [s[0], s[1], s[2]], halfExtent: s[3] };
  }
}

/** A loaded packed take and its reader, with buffers for one frame. */
export class LoadedTake {
  constructor(runtime, bytes) {
    const { fb, arena } = runtime;
    this.runtime = runtime;
    this.bytes = runtime.copyIn(bytes);
    this.ptr = arena.reserve(fb.fb_take_size(), fb.fb_take_align());
    runtime.check(fb.fb_take_load(this.bytes, bytes.length, this.ptr, fb.fb_take_size()), 'fb_take_load');
    this.frameCount = fb.fb_take_frame_count(this.ptr);
    this.markerCount = fb.fb_take_marker_count(this.ptr);
    this.rate = fb.fb_take_rate(this.ptr);
    this.markerNames = runtime.names(fb.fb_take_marker_name, this.ptr, this.markerCount, 'fb_take_marker_name');
    this.space = runtime.space(fb.fb_take_space, this.ptr, 'fb_take_space');
    this.samples = arena.reserve(12 * this.markerCount, 4);
    this.present = arena.reserve(this.markerCount, 1);
    this.frame = arena.reserve(4, 4);
  }

  /**
   * Decode the next frame into `samplesView()` / `presentView()`: its index, or -1 after the
   * last frame (FB_ERROR_END_OF_TAKE).
   */
  next() {
    const rt = this.runtime;
    const code = rt.fb.fb_take_next_frame(this.ptr, this.samples, this.present, this.markerCount, this.frame);
    if (code === END_OF_TAKE) {
      return -1;
    }
    rt.check(code, 'fb_take_next_frame');
    return rt.u32(this.frame, 1)[0];
  }

  /** Make `frame` the next one decoded. */
  seek(frame) {
    this.runtime.check(this.runtime.fb.fb_take_seek(this.ptr, frame), 'fb_take_seek');
  }

  samplesView() {
    return this.runtime.i32(this.samples, 3 * this.markerCount);
  }
  presentView() {
    return this.runtime.bytes(this.present, this.markerCount);
  }
}

/** A loaded rig with the buffers of one character: markers, vertices, normals, a play state. */
export class LoadedRig {
  constructor(runtime, blob) {
    const { fb, arena } = runtime;
    this.runtime = runtime;
    this.blob = runtime.copyIn(blob);
    this.ptr = arena.reserve(fb.fb_rig_size(), fb.fb_rig_align());
    runtime.check(fb.fb_rig_load(this.blob, blob.length, this.ptr, fb.fb_rig_size()), 'fb_rig_load');
    this.vertexCount = fb.fb_rig_vertex_count(this.ptr);
    this.markerCount = fb.fb_rig_marker_count(this.ptr);
    this.hasStages = fb.fb_rig_has_stages(this.ptr) !== 0;
    this.markerNames = runtime.names(fb.fb_marker_name, this.ptr, this.markerCount, 'fb_marker_name');
    this.space = runtime.space(fb.fb_rig_space, this.ptr, 'fb_rig_space');
    this.actorSpace = this.hasStages ? runtime.space(fb.fb_rig_actor_space, this.ptr, 'fb_rig_actor_space') : null;

    const m = this.markerCount;
    const v = this.vertexCount;
    this.markers = arena.reserve(12 * m, 4); // input of deform: Q8.24 rig units
    this.actor = arena.reserve(12 * m, 4); // input of play: Q8.24 actor units
    this.present = arena.reserve(m, 1);
    this.character = arena.reserve(12 * m, 4); // play's character markers
    this.out = arena.reserve(12 * v, 4);
    this.normalsOut = arena.reserve(6 * v, 2);
    // The normals plan (each triangle once) and a sum per vertex: fb_normals_planned gives
    // fb_normals's normals bit for bit with a third of the cross products.
    this.planLen = fb.fb_normals_plan_len(this.ptr);
    this.plan = arena.reserve(12 * this.planLen, 4);
    this.sums = arena.reserve(24 * v, 8);
    this.runtime.check(fb.fb_plan_normals(this.ptr, this.plan, this.planLen), 'fb_plan_normals');
    this.report = arena.reserve(REPORT_BYTES, 4);
    if (this.hasStages) {
      this.state = arena.reserve(fb.fb_play_state_size(), fb.fb_play_state_align());
      this.resetState();
    }
  }

  /** A fresh play state: the character's first frame comes next. */
  resetState() {
    const { fb } = this.runtime;
    this.runtime.check(fb.fb_play_state_init(this.state, fb.fb_play_state_size()), 'fb_play_state_init');
  }

  /** The vertices' rest positions in asset units (`fb_vertex_rest_f32`). */
  vertexRest() {
    const rt = this.runtime;
    rt.check(rt.fb.fb_vertex_rest_f32(this.ptr, this.out, this.vertexCount), 'fb_vertex_rest_f32');
    return rt.f32(this.out, 3 * this.vertexCount).slice();
  }

  /** Deform from the Q8.24 rig-unit markers in `markerView()` into `outView()`. */
  deform() {
    const rt = this.runtime;
    rt.check(rt.fb.fb_deform(this.ptr, this.markers, this.markerCount, this.out, this.vertexCount), 'fb_deform');
  }

  /**
   * Play the actor frame in `actorView()` / `presentView()` through the capture stages and the
   * deformer; returns { rigidResidual, rebuiltCount, heldCount } of the frame's report.
   */
  play() {
    const rt = this.runtime;
    rt.check(
      rt.fb.fb_play(this.ptr, this.state, this.actor, this.present, this.markerCount, this.character, this.out, this.vertexCount, this.report),
      'fb_play',
    );
    const r = rt.i32(this.report, 7);
    return { rigidResidual: r[2], rebuiltCount: r[5] >>> 0, heldCount: r[6] >>> 0 };
  }

  /** The unit normals (Q1.14) of the positions in `outView()`, into `normalsView()`. */
  normals() {
    const rt = this.runtime;
    rt.check(
      rt.fb.fb_normals_planned(
        this.ptr, this.plan, this.planLen, this.out, this.vertexCount,
        this.sums, this.vertexCount, this.normalsOut, this.vertexCount,
      ),
      'fb_normals_planned',
    );
  }

  markerView() {
    return this.runtime.i32(this.markers, 3 * this.markerCount);
  }
  actorView() {
    return this.runtime.i32(this.actor, 3 * this.markerCount);
  }
  presentView() {
    return this.runtime.bytes(this.present, this.markerCount);
  }
  characterView() {
    return this.runtime.i32(this.character, 3 * this.markerCount);
  }
  outView() {
    return this.runtime.i32(this.out, 3 * this.vertexCount);
  }
  normalsView() {
    return this.runtime.i16(this.normalsOut, 3 * this.vertexCount);
  }
}

/**
 * Q8.24 positions → asset units (`Space::to_asset`): `centre + q · half_extent / 2^24`, in
 * f64, stored into `target` (a Float32Array or a plain array).
 */
export function toAsset(space, q, target) {
  const scale = space.halfExtent / POS_ONE;
  for (let i = 0; i < q.length; i++) {
    target[i] = space.centre[i % 3] + q[i] * scale;
  }
}

/**
 * Asset units → Q8.24 (`Space::to_rig_f64`): `(p − centre) / half_extent · 2^24`, rounded half
 * away from zero; null when not finite or beyond the `i32` range (the runtime's ConvertError).
 */
export function toRig(space, p) {
  const q = [0, 0, 0];
  for (let c = 0; c < 3; c++) {
    if (!Number.isFinite(p[c])) {
      return null;
    }
    const x = ((p[c] - space.centre[c]) / space.halfExtent) * POS_ONE;
    if (!(x >= -2147483648 && x < 2147483647.5)) {
      return null;
    }
    q[c] = x >= 0 ? Math.trunc(x + 0.5) : Math.trunc(x - 0.5);
  }
  return q;
}

/**
 * FNV-1a, 64-bit (`checksum::Fnv1a64`), over bytes, in two 32-bit halves: the prime is
 * 2^40 + 0x1b3, so h · prime = h · 0x1b3 + (h << 40) modulo 2^64.
 */
export class Fnv1a64 {
  constructor() {
    this.hi = 0xcbf29ce4;
    this.lo = 0x84222325;
  }

  /** Feed the bytes of `view` (any typed array; wasm memory and JS are little-endian). */
  write(view) {
    const b = new Uint8Array(view.buffer, view.byteOffset, view.byteLength);
    let { hi, lo } = this;
    for (let i = 0; i < b.length; i++) {
      lo = (lo ^ b[i]) >>> 0;
      const p = lo * 0x1b3; // < 2^41: exact
      const nlo = p >>> 0;
      hi = (Math.imul(hi, 0x1b3) + (p - nlo) / 4294967296 + (lo << 8)) >>> 0;
      lo = nlo;
    }
    this.hi = hi;
    this.lo = lo;
  }

  /** The hash as 16 lowercase hex digits, as the golden files print it. */
  hex() {
    return this.hi.toString(16).padStart(8, '0') + this.lo.toString(16).padStart(8, '0');
  }
}
