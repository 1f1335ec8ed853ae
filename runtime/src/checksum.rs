//! Checksums: CRC-32 over the blob payload, and FNV-1a-64 over output frames.
//!
//! * CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320) seals the blob. The table is built at
//!   compile time, so the check costs 1 KiB of flash and one table look-up per byte, at load time
//!   only.
//! * [`Fnv1a64`] fingerprints deformed vertex buffers, so the golden tests (host, cross-built
//!   targets under emulation, the Cortex-M4 firmware) compare frames by one short number each. It
//!   is never on the per-frame path of [`crate::Rig::deform`].

const TABLE: [u32; 256] = build_table();

const fn build_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

/// CRC-32 of `bytes` (the same value as zlib's `crc32`).
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c = TABLE[usize::from((c as u8) ^ b)] ^ (c >> 8);
    }
    !c
}

#[cfg(feature = "format")]
/// FNV-1a, 64-bit: a tiny, table-free hash, identical on every platform because it is defined on
/// bytes. Positions are hashed as `i32` little-endian, x y z per vertex, whatever the host's byte
/// order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a64(u64);

#[cfg(feature = "format")]
impl Fnv1a64 {
    const OFFSET_BASIS: u64 = 0xCBF2_9CE4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01B3;

    /// A hash of nothing yet.
    pub const fn new() -> Self {
        Self(Self::OFFSET_BASIS)
    }

    /// Feed bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(Self::PRIME);
        }
    }

    /// Feed positions (Q8.24) as `i32` LE, x y z per entry.
    pub fn write_positions(&mut self, positions: &[[i32; 3]]) {
        for p in positions {
            for c in p {
                self.write(&c.to_le_bytes());
            }
        }
    }

    /// Feed actor samples as the golden actor files store them: per marker a presence byte
    /// (1 present, 0 missing) and three `i32` LE (zeros when missing).
    pub fn write_samples(&mut self, samples: &[Option<[i32; 3]>]) {
        for s in samples {
            self.write(&[u8::from(s.is_some())]);
            self.write_positions(&[s.unwrap_or([0; 3])]);
        }
    }

    /// Feed unit normals (Q1.14) as `i16` LE, x y z per entry.
    pub fn write_normals(&mut self, normals: &[[i16; 3]]) {
        for n in normals {
            for c in n {
                self.write(&c.to_le_bytes());
            }
        }
    }

    /// Feed one frame of the capture stages as the golden hashes record it: the character's
    /// markers, the deformed vertices, then (RMS head residual, markers rebuilt, markers held).
    pub fn write_capture_frame(
        &mut self,
        markers: &[[i32; 3]],
        vertices: &[[i32; 3]],
        report: &crate::stages::report::FrameReport,
    ) {
        self.write_positions(markers);
        self.write_positions(vertices);
        self.write_positions(&[[
            report.rigid_residual,
            report.rebuilt.len() as i32,
            report.held.len() as i32,
        ]]);
    }

    /// The hash of everything fed so far.
    pub const fn finish(&self) -> u64 {
        self.0
    }
}

#[cfg(feature = "format")]
impl Default for Fnv1a64 {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::{crc32, Fnv1a64};

    #[test]
    fn fnv1a64_known_answers() {
        let hash = |b: &[u8]| {
            let mut h = Fnv1a64::new();
            h.write(b);
            h.finish()
        };
        // The reference values of the FNV authors' test suite.
        assert_eq!(hash(b""), 0xCBF2_9CE4_8422_2325);
        assert_eq!(hash(b"a"), 0xAF63_DC4C_8601_EC8C);
        assert_eq!(hash(b"foobar"), 0x8594_4171_F739_67E8);
        // Positions are hashed little-endian whatever the host's byte order.
        let mut h = Fnv1a64::new();
        h.write_positions(&[[1, -2, 0x0102_0304]]);
        assert_eq!(
            h.finish(),
            hash(&[1, 0, 0, 0, 0xFE, 0xFF, 0xFF, 0xFF, 4, 3, 2, 1])
        );
        let mut h = Fnv1a64::new();
        h.write_normals(&[[1, -2, 0x0102]]);
        assert_eq!(h.finish(), hash(&[1, 0, 0xFE, 0xFF, 2, 1]));
    }

    #[test]
    fn known_answers() {
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(
            crc32(b"The quick brown fox jumps over the lazy dog"),
            0x414F_A339
        );
    }
}
