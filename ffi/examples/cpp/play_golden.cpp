// Plays the bundled golden rigs and take through the facebake C ABI from C++ and prints each
// frame's FNV-1a-64 hash in the format of fixtures/golden/hashes.txt (and hashes_planar.txt);
// .ci/ffi.sh compares them with what the Rust golden tests recorded. The same program as
// ../c/play_golden.c, written the way a C++ engine would wrap the ABI: RAII owners for the blob,
// the rig storage and the play state, and exceptions for error codes.
//
//   play_golden fixtures/golden
//
// Build (from the repository root; .ci/ffi.sh does this):
//   c++ -std=c++17 -I ffi/include ffi/examples/cpp/play_golden.cpp
//       target/release/libfacebake_ffi.a -lpthread -ldl -lm
#include "facebake.h"

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

namespace facebake {

// Throws on a failed call, with the library's message.
inline void check(FbError status, const std::string &what) {
    if (status != FB_ERROR_NONE) {
        throw std::runtime_error(what + ": " + fb_error_message(status));
    }
}

// Caller-owned storage of a given size and alignment (what the ABI asks for instead of
// allocating itself).
class Storage {
  public:
    Storage(std::size_t size, std::size_t align)
        : bytes_(static_cast<unsigned char *>(::operator new(size, std::align_val_t(align))),
                 Free{align}),
          size_(size) {}
    void *data() const { return bytes_.get(); }
    std::size_t size() const { return size_; }

  private:
    struct Free {
        std::size_t align;
        void operator()(unsigned char *p) const { ::operator delete(p, std::align_val_t(align)); }
    };
    std::unique_ptr<unsigned char, Free> bytes_;
    std::size_t size_;
};

// A loaded rig: owns the blob (which the rig borrows) and the rig's storage. Immutable once
// loaded, so one Rig may be shared by every thread and character.
class Rig {
  public:
    explicit Rig(std::vector<std::uint8_t> blob)
        : blob_(std::move(blob)), storage_(fb_rig_size(), fb_rig_align()) {
        check(fb_rig_load(blob_.data(), blob_.size(), rig(), storage_.size()), "fb_rig_load");
    }
    Rig(const Rig &) = delete;
    Rig &operator=(const Rig &) = delete;

    const FbRig *get() const { return static_cast<const FbRig *>(storage_.data()); }
    std::size_t vertices() const { return fb_rig_vertex_count(get()); }
    std::size_t markers() const { return fb_rig_marker_count(get()); }

    std::string marker_name(std::size_t i) const {
        const char *name = nullptr;
        std::size_t len = 0;
        check(fb_marker_name(get(), i, &name, &len), "fb_marker_name");
        return std::string(name, len);
    }

    // One frame: markers in, vertices out (Q8.24 rig units).
    void deform(const std::vector<std::int32_t> &markers, std::vector<std::int32_t> &out) const {
        out.resize(vertices() * 3);
        check(fb_deform(get(), markers.data(), markers.size() / 3, out.data(), vertices()),
              "fb_deform");
    }

  private:
    FbRig *rig() { return static_cast<FbRig *>(storage_.data()); }
    std::vector<std::uint8_t> blob_; // must outlive the rig: declared first, destroyed last
    Storage storage_;
};

// The frame-to-frame state of ONE character playing a capture through a rig.
class Character {
  public:
    explicit Character(const Rig &rig)
        : rig_(rig), state_(fb_play_state_size(), fb_play_state_align()),
          markers_(rig.markers() * 3), vertices_(rig.vertices() * 3) {
        check(fb_play_state_init(state(), state_.size()), "fb_play_state_init");
    }

    // One captured frame: actor markers (Q8.24 actor units) and which are present.
    FbFrameReport play(const std::vector<std::int32_t> &actor,
                       const std::vector<std::uint8_t> &present) {
        FbFrameReport report{};
        check(fb_play(rig_.get(), state(), actor.data(), present.data(), present.size(),
                      markers_.data(), vertices_.data(), rig_.vertices(), &report),
              "fb_play");
        return report;
    }
    const std::vector<std::int32_t> &markers() const { return markers_; }
    const std::vector<std::int32_t> &vertices() const { return vertices_; }

  private:
    FbPlayState *state() { return static_cast<FbPlayState *>(state_.data()); }
    const Rig &rig_;
    Storage state_;
    std::vector<std::int32_t> markers_;
    std::vector<std::int32_t> vertices_;
};

} // namespace facebake

namespace {

std::vector<std::uint8_t> read_file(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw std::runtime_error("cannot open " + path);
    }
    return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

std::int32_t le_i32(const std::uint8_t *p) {
    return static_cast<std::int32_t>(std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 |
                                     std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24);
}

// FNV-1a, 64-bit, fed i32 values as little-endian bytes.
struct Fnv1a64 {
    std::uint64_t state = 0xcbf29ce484222325ull;
    void write(const std::int32_t *values, std::size_t n) {
        for (std::size_t i = 0; i < n; i++) {
            auto v = static_cast<std::uint32_t>(values[i]);
            for (int b = 0; b < 4; b++) {
                state = (state ^ ((v >> (8 * b)) & 0xff)) * 0x100000001b3ull;
            }
        }
    }
    void write(const std::vector<std::int32_t> &v) { write(v.data(), v.size()); }
};

void print(const std::string &name, const std::string &what, std::uint64_t hash) {
    std::printf("%s %s %016" PRIx64 "\n", name.c_str(), what.c_str(), hash);
}

// Every frame of the marker file `frames` through Rig::deform.
void deform_take(const std::string &dir, const std::string &name, const std::string &file,
                 const std::string &frames) {
    facebake::Rig rig(read_file(dir + "/" + file));
    std::fprintf(stderr, "%s: %zu vertices, %zu markers (first: %s)\n", file.c_str(),
                 rig.vertices(), rig.markers(), rig.marker_name(0).c_str());
    const auto take = read_file(dir + "/" + frames);
    const std::size_t words = rig.markers() * 3;
    std::vector<std::int32_t> markers(words), out;
    Fnv1a64 sequence;
    for (std::size_t f = 0; (f + 1) * words * 4 <= take.size(); f++) {
        for (std::size_t i = 0; i < words; i++) {
            markers[i] = le_i32(&take[(f * words + i) * 4]);
        }
        rig.deform(markers, out);
        Fnv1a64 h;
        h.write(out);
        sequence.write(out);
        print(name, "frame " + std::to_string(f), h.state);
    }
    print(name, "sequence", sequence.state);
}

void play_take(const std::string &dir) {
    const facebake::Rig rig(read_file(dir + "/jawmocap_capture.fbk"));
    facebake::Character character(rig);
    const auto take = read_file(dir + "/jawmocap_actor.bin");
    const std::size_t m = rig.markers(), record = 1 + 3 * 4;
    std::vector<std::int32_t> actor(m * 3);
    std::vector<std::uint8_t> present(m);
    Fnv1a64 sequence;
    for (std::size_t f = 0; (f + 1) * m * record <= take.size(); f++) {
        const std::uint8_t *frame = &take[f * m * record];
        for (std::size_t j = 0; j < m; j++) {
            present[j] = frame[j * record];
            for (std::size_t c = 0; c < 3; c++) {
                actor[3 * j + c] = le_i32(frame + j * record + 1 + 4 * c);
            }
        }
        const FbFrameReport report = character.play(actor, present);
        const std::int32_t tail[3] = {report.rigid_residual,
                                      static_cast<std::int32_t>(report.rebuilt_count),
                                      static_cast<std::int32_t>(report.held_count)};
        Fnv1a64 h;
        for (Fnv1a64 *hash : {&h, &sequence}) {
            hash->write(character.markers());
            hash->write(character.vertices());
            hash->write(tail, 3);
        }
        print("capture", "frame " + std::to_string(f), h.state);
    }
    print("capture", "sequence", sequence.state);
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s FIXTURES_GOLDEN_DIR\n", argv[0]);
        return 2;
    }
    try {
        if (fb_abi_version() != FB_ABI_VERSION) {
            throw std::runtime_error("header and library ABI versions differ");
        }
        const std::string dir = argv[1];
        deform_take(dir, "coefficients", "facecap_coefficients.fbk", "facecap_markers.bin");
        deform_take(dir, "weights", "facecap_weights.fbk", "facecap_markers.bin");
        deform_take(dir, "coefficients_k4", "facecap_coefficients_k4.fbk", "facecap_markers.bin");
        deform_take(dir, "product", "facecap_product.fbk", "facecap_layout_markers.bin");
        deform_take(dir, "planar", "facecap_planar.fbk", "facecap_markers.bin");
        play_take(dir);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "play_golden: %s\n", e.what());
        return 1;
    }
    return 0;
}
