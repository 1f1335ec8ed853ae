/*
 * Plays the bundled golden rigs and take through the facebake C ABI and prints each frame's
 * FNV-1a-64 hash in the format of fixtures/golden/hashes.txt (and hashes_planar.txt), so that
 * .ci/ffi.sh can compare them line by line with what the Rust golden tests recorded.
 *
 *   play_golden fixtures/golden
 *
 * Deform rigs: every frame of facecap_markers.bin (facecap_layout_markers.bin for the product
 * rig) through fb_deform (odd frames split as a job
 * system would: fb_prepare once, then fb_deform_chunk on two halves). Capture rig: every frame of
 * jawmocap_actor.bin through fb_play (capture stages, then the deformer), hashing the
 * character's markers, the vertices and (head residual, rebuilt count, held count), as
 * tests/tests/golden.rs does; then the packed take jawmocap.fbt through fb_take_next_frame and
 * fb_play, hashed as fixtures/golden/hashes_take.txt records it. After each frame, its normals through fb_normals, hashed as
 * fixtures/golden/hashes_normals.txt records them and printed behind the word "normals"; the
 * same frame through fb_normals_planned (the rig's plan made once, at load) must give the same
 * bytes. Only hash lines go to stdout; a summary of each rig goes to stderr.
 *
 * Build: cc -std=c11 -I ffi/include play_golden.c target/release/libfacebake_ffi.a \
 *            -lpthread -ldl -lm
 */
#include "facebake.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Stop with a message when a call fails. */
static void check(FbError status, const char *what) {
    if (status != FB_ERROR_NONE) {
        fprintf(stderr, "play_golden: %s: %s (code %d)\n", what, fb_error_message(status),
                (int)status);
        exit(1);
    }
}

static void *xmalloc(size_t n) {
    void *p = malloc(n ? n : 1);
    if (!p) {
        fprintf(stderr, "play_golden: out of memory\n");
        exit(1);
    }
    return p;
}

/* `size` bytes aligned to `align` (a power of two), released with free(). */
static void *aligned_storage(size_t size, size_t align) {
    size_t rounded = (size + align - 1) / align * align;
    void *p = aligned_alloc(align, rounded);
    if (!p) {
        fprintf(stderr, "play_golden: out of memory\n");
        exit(1);
    }
    return p;
}

/* The whole file dir/name, or exit. */
static uint8_t *read_file(const char *dir, const char *name, size_t *len) {
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "play_golden: cannot open %s\n", path);
        exit(1);
    }
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *bytes = xmalloc((size_t)size);
    if (size < 0 || fread(bytes, 1, (size_t)size, f) != (size_t)size) {
        fprintf(stderr, "play_golden: cannot read %s\n", path);
        exit(1);
    }
    fclose(f);
    *len = (size_t)size;
    return bytes;
}

/* A little-endian i32 at p. */
static int32_t le_i32(const uint8_t *p) {
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

/* FNV-1a, 64-bit, fed i32 values as little-endian bytes (whatever the host's byte order). */
typedef struct {
    uint64_t state;
} Fnv1a64;

static Fnv1a64 fnv_new(void) {
    Fnv1a64 h = {UINT64_C(0xcbf29ce484222325)};
    return h;
}

static void fnv_i32s(Fnv1a64 *h, const int32_t *values, size_t n) {
    for (size_t i = 0; i < n; i++) {
        uint32_t v = (uint32_t)values[i];
        for (int b = 0; b < 4; b++) {
            h->state = (h->state ^ ((v >> (8 * b)) & 0xff)) * UINT64_C(0x100000001b3);
        }
    }
}

/* The same, fed i16 values (the normals). */
static void fnv_i16s(Fnv1a64 *h, const int16_t *values, size_t n) {
    for (size_t i = 0; i < n; i++) {
        uint16_t v = (uint16_t)values[i];
        for (int b = 0; b < 2; b++) {
            h->state = (h->state ^ ((v >> (8 * b)) & 0xff)) * UINT64_C(0x100000001b3);
        }
    }
}

/* A rig loaded into malloc'd storage, with the blob it borrows, and its normals plan and
 * scratch sums for fb_normals_planned. */
typedef struct {
    uint8_t *blob;
    FbRig *rig;
    size_t vertices;
    size_t markers;
    uint32_t *plan;
    size_t plan_len;
    int64_t *sums;
    int16_t *planned;
} Loaded;

/* The normals of the positions `out` through fb_normals: hashed into `sequence`, printed; the
 * planned normals of the same positions must be the same bytes. */
static void normals_frame(const Loaded *l, const char *name, size_t f, const int32_t *out,
                          int16_t *normals, Fnv1a64 *sequence) {
    check(fb_normals(l->rig, out, l->vertices, normals, l->vertices), "fb_normals");
    check(fb_normals_planned(l->rig, l->plan, l->plan_len, out, l->vertices, l->sums,
                             l->vertices, l->planned, l->vertices),
          "fb_normals_planned");
    if (memcmp(normals, l->planned, l->vertices * 3 * sizeof *normals) != 0) {
        fprintf(stderr, "play_golden: %s frame %zu: planned normals differ\n", name, f);
        exit(1);
    }
    Fnv1a64 h = fnv_new();
    fnv_i16s(&h, normals, l->vertices * 3);
    fnv_i16s(sequence, normals, l->vertices * 3);
    printf("normals %s frame %zu %016" PRIx64 "\n", name, f, h.state);
}

static Loaded load(const char *dir, const char *file) {
    Loaded l;
    size_t len;
    l.blob = read_file(dir, file, &len);
    l.rig = aligned_storage(fb_rig_size(), fb_rig_align());
    check(fb_rig_load(l.blob, len, l.rig, fb_rig_size()), file);
    l.vertices = fb_rig_vertex_count(l.rig);
    l.markers = fb_rig_marker_count(l.rig);
    l.plan_len = fb_normals_plan_len(l.rig);
    l.plan = xmalloc(l.plan_len * 3 * sizeof *l.plan);
    check(fb_plan_normals(l.rig, l.plan, l.plan_len), "fb_plan_normals");
    l.sums = xmalloc(l.vertices * 3 * sizeof *l.sums);
    l.planned = xmalloc(l.vertices * 3 * sizeof *l.planned);

    FbCost cost;
    check(fb_cost(l.rig, &cost), "fb_cost");
    const char *first;
    size_t first_len;
    check(fb_marker_name(l.rig, 0, &first, &first_len), "fb_marker_name");
    fprintf(stderr, "%s: %zu vertices, %zu markers (first: %.*s), %" PRIu64
                    " multiply-adds per frame%s\n",
            file, l.vertices, l.markers, (int)first_len, first, cost.multiply_adds,
            fb_rig_has_stages(l.rig) ? ", capture stages" : "");
    return l;
}

static void unload(Loaded *l) {
    free(l->rig); /* the rig owns nothing: freeing its storage is all */
    free(l->blob);
    free(l->plan);
    free(l->sums);
    free(l->planned);
}

/* Every frame of the marker file `frames` through fb_deform. */
static void deform_take(const char *dir, const char *name, const char *file, const char *frames) {
    Loaded l = load(dir, file);
    size_t len;
    uint8_t *take = read_file(dir, frames, &len);
    size_t frame_bytes = l.markers * 3 * 4;
    int32_t *markers = xmalloc(frame_bytes);
    int32_t *out = xmalloc(l.vertices * 3 * sizeof(int32_t));
    int16_t *normals = xmalloc(l.vertices * 3 * sizeof(int16_t));
    FbFrameTable *table = aligned_storage(fb_frame_table_size(), fb_frame_table_align());
    size_t half = l.vertices / 2;
    Fnv1a64 sequence = fnv_new();
    Fnv1a64 normals_sequence = fnv_new();
    for (size_t f = 0; (f + 1) * frame_bytes <= len; f++) {
        for (size_t i = 0; i < l.markers * 3; i++) {
            markers[i] = le_i32(take + f * frame_bytes + 4 * i);
        }
        if (f % 2 == 0) {
            check(fb_deform(l.rig, markers, l.markers, out, l.vertices), "fb_deform");
        } else {
            /* The frame's marker work once, then each half as a worker would. */
            check(fb_prepare(l.rig, markers, l.markers, table, fb_frame_table_size()),
                  "fb_prepare");
            check(fb_deform_chunk(l.rig, table, 0, out, half), "fb_deform_chunk");
            check(fb_deform_chunk(l.rig, table, half, out + 3 * half, l.vertices - half),
                  "fb_deform_chunk");
        }
        Fnv1a64 h = fnv_new();
        fnv_i32s(&h, out, l.vertices * 3);
        fnv_i32s(&sequence, out, l.vertices * 3);
        printf("%s frame %zu %016" PRIx64 "\n", name, f, h.state);
        normals_frame(&l, name, f, out, normals, &normals_sequence);
    }
    printf("%s sequence %016" PRIx64 "\n", name, sequence.state);
    printf("normals %s sequence %016" PRIx64 "\n", name, normals_sequence.state);
    free(table);
    free(normals);
    free(out);
    free(markers);
    free(take);
    unload(&l);
}

/* Every frame of jawmocap_actor.bin through fb_play, with one play state (one character). */
static void play_take(const char *dir) {
    Loaded l = load(dir, "jawmocap_capture.fbk");
    FbPlayState *state = aligned_storage(fb_play_state_size(), fb_play_state_align());
    check(fb_play_state_init(state, fb_play_state_size()), "fb_play_state_init");
    size_t len;
    uint8_t *take = read_file(dir, "jawmocap_actor.bin", &len);
    size_t record = 1 + 3 * 4; /* present byte, x y z */
    size_t frame_bytes = l.markers * record;
    int32_t *actor = xmalloc(l.markers * 3 * sizeof(int32_t));
    uint8_t *present = xmalloc(l.markers);
    int32_t *character = xmalloc(l.markers * 3 * sizeof(int32_t));
    int32_t *out = xmalloc(l.vertices * 3 * sizeof(int32_t));
    int16_t *normals = xmalloc(l.vertices * 3 * sizeof(int16_t));
    Fnv1a64 sequence = fnv_new();
    Fnv1a64 normals_sequence = fnv_new();
    for (size_t f = 0; (f + 1) * frame_bytes <= len; f++) {
        const uint8_t *frame = take + f * frame_bytes;
        for (size_t j = 0; j < l.markers; j++) {
            present[j] = frame[j * record];
            for (size_t c = 0; c < 3; c++) {
                actor[3 * j + c] = le_i32(frame + j * record + 1 + 4 * c);
            }
        }
        FbFrameReport report;
        check(fb_play(l.rig, state, actor, present, l.markers, character, out, l.vertices,
                      &report),
              "fb_play");
        int32_t tail[3] = {report.rigid_residual, (int32_t)report.rebuilt_count,
                           (int32_t)report.held_count};
        Fnv1a64 h = fnv_new();
        Fnv1a64 *hs[2] = {&h, &sequence};
        for (int k = 0; k < 2; k++) {
            fnv_i32s(hs[k], character, l.markers * 3);
            fnv_i32s(hs[k], out, l.vertices * 3);
            fnv_i32s(hs[k], tail, 3);
        }
        printf("capture frame %zu %016" PRIx64 "\n", f, h.state);
        normals_frame(&l, "capture", f, out, normals, &normals_sequence);
    }
    printf("capture sequence %016" PRIx64 "\n", sequence.state);
    printf("normals capture sequence %016" PRIx64 "\n", normals_sequence.state);
    free(normals);
    free(out);
    free(character);
    free(present);
    free(actor);
    free(take);
    free(state);
    unload(&l);
}

/* The index of `name` (`len` bytes) among the take's markers, or SIZE_MAX. */
static size_t take_marker(const FbTake *take, const char *name, size_t len) {
    for (size_t k = 0; k < fb_take_marker_count(take); k++) {
        const char *other;
        size_t other_len;
        check(fb_take_marker_name(take, k, &other, &other_len), "fb_take_marker_name");
        if (other_len == len && memcmp(other, name, len) == 0) {
            return k;
        }
    }
    return SIZE_MAX;
}

/* The packed take jawmocap.fbt decoded by fb_take_next_frame and played through fb_play, hashed
 * as fixtures/golden/hashes_take.txt records it: each rig marker's sample (present byte, x y z),
 * then the character's markers, the vertices and (head residual, rebuilt, held). */
static void play_packed_take(const char *dir) {
    Loaded l = load(dir, "jawmocap_capture.fbk");
    size_t len;
    uint8_t *bytes = read_file(dir, "jawmocap.fbt", &len);
    FbTake *take = aligned_storage(fb_take_size(), fb_take_align());
    check(fb_take_load(bytes, len, take, fb_take_size()), "fb_take_load");
    size_t tm = fb_take_marker_count(take);
    size_t *map = xmalloc(l.markers * sizeof(size_t)); /* take marker of each rig marker */
    for (size_t j = 0; j < l.markers; j++) {
        const char *name;
        size_t name_len;
        check(fb_marker_name(l.rig, j, &name, &name_len), "fb_marker_name");
        map[j] = take_marker(take, name, name_len);
    }
    FbPlayState *state = aligned_storage(fb_play_state_size(), fb_play_state_align());
    check(fb_play_state_init(state, fb_play_state_size()), "fb_play_state_init");
    int32_t *samples = xmalloc(tm * 3 * sizeof(int32_t));
    uint8_t *present = xmalloc(tm);
    int32_t *actor = xmalloc(l.markers * 3 * sizeof(int32_t));
    uint8_t *given = xmalloc(l.markers);
    int32_t *character = xmalloc(l.markers * 3 * sizeof(int32_t));
    int32_t *out = xmalloc(l.vertices * 3 * sizeof(int32_t));
    Fnv1a64 sequence = fnv_new();
    size_t f;
    FbError status;
    while ((status = fb_take_next_frame(take, samples, present, tm, &f)) == FB_ERROR_NONE) {
        Fnv1a64 h = fnv_new();
        Fnv1a64 *hs[2] = {&h, &sequence};
        for (size_t j = 0; j < l.markers; j++) {
            size_t k = map[j];
            given[j] = k != SIZE_MAX && present[k];
            for (size_t c = 0; c < 3; c++) {
                actor[3 * j + c] = given[j] ? samples[3 * k + c] : 0;
            }
            for (int i = 0; i < 2; i++) {
                hs[i]->state = (hs[i]->state ^ given[j]) * UINT64_C(0x100000001b3);
                fnv_i32s(hs[i], actor + 3 * j, 3);
            }
        }
        FbFrameReport report;
        check(fb_play(l.rig, state, actor, given, l.markers, character, out, l.vertices, &report),
              "fb_play");
        int32_t tail[3] = {report.rigid_residual, (int32_t)report.rebuilt_count,
                           (int32_t)report.held_count};
        for (int i = 0; i < 2; i++) {
            fnv_i32s(hs[i], character, l.markers * 3);
            fnv_i32s(hs[i], out, l.vertices * 3);
            fnv_i32s(hs[i], tail, 3);
        }
        printf("take frame %zu %016" PRIx64 "\n", f, h.state);
    }
    if (status != FB_ERROR_END_OF_TAKE) {
        check(status, "fb_take_next_frame");
    }
    printf("take sequence %016" PRIx64 "\n", sequence.state);
    fprintf(stderr, "jawmocap.fbt: %zu frames at %g Hz, %zu markers\n", fb_take_frame_count(take),
            fb_take_rate(take), tm);
    free(out);
    free(character);
    free(given);
    free(actor);
    free(present);
    free(samples);
    free(state);
    free(map);
    free(take);
    free(bytes);
    unload(&l);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s FIXTURES_GOLDEN_DIR\n", argv[0]);
        return 2;
    }
    if (fb_abi_version() != FB_ABI_VERSION) {
        fprintf(stderr, "play_golden: header and library ABI versions differ\n");
        return 1;
    }
    const char *dir = argv[1];
    deform_take(dir, "coefficients", "facecap_coefficients.fbk", "facecap_markers.bin");
    deform_take(dir, "weights", "facecap_weights.fbk", "facecap_markers.bin");
    deform_take(dir, "coefficients_k4", "facecap_coefficients_k4.fbk", "facecap_markers.bin");
    deform_take(dir, "product", "facecap_product.fbk", "facecap_layout_markers.bin");
    deform_take(dir, "planar", "facecap_planar.fbk", "facecap_markers.bin");
    play_take(dir);
    play_packed_take(dir);
    return 0;
}
