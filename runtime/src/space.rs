//! [`Space`]: where rig units sit in the asset's space, and the host-side conversions between
//! the asset's units and rig units (Q8.24).
//!
//! The conversions use floating point and are meant for the host (or a capture front end), not
//! for the per-frame path, which is integer only. Loading checks a space on the bits of its
//! floats ([`Space::is_valid`]), so a core without an FPU links no soft-float code.

use serde::{Deserialize, Serialize};

use crate::fixed::{POS_FRAC_BITS, POS_ONE, REST_SHIFT};

/// Where rig units sit in the asset's space: `rig = (asset − centre) / half_extent`, in Q8.24.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Space {
    /// Centre of the mesh bounds, asset units.
    pub centre: [f32; 3],
    /// Half the largest side of the mesh bounds (slightly enlarged so the mesh fits Q0.15),
    /// asset units per rig unit.
    pub half_extent: f32,
}

/// A marker position that cannot be expressed in rig units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConvertError {
    /// A coordinate is NaN or infinite.
    NotFinite,
    /// A coordinate lies beyond ±128 half extents of the mesh (outside Q8.24).
    OutOfRange,
}

impl core::fmt::Display for ConvertError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite => f.write_str("position is not finite"),
            Self::OutOfRange => {
                f.write_str("position is outside the rig's range (±128 half extents)")
            }
        }
    }
}

impl core::error::Error for ConvertError {}

fn round_to_i64(x: f64) -> i64 {
    // core has no f64::round; `as` truncates toward zero, so shift by ½ away from zero first.
    if x >= 0.0 {
        (x + 0.5) as i64
    } else {
        (x - 0.5) as i64
    }
}

/// `x.is_finite()`, on the IEEE-754 bits: the exponent is not all ones. Integer-only, so loading
/// a rig needs no floating-point code on a core without an FPU (no soft-float routines linked).
fn f32_is_finite(x: f32) -> bool {
    x.to_bits() & 0x7F80_0000 != 0x7F80_0000
}

/// `x > 0.0`, on the IEEE-754 bits: sign clear, not ±0, not NaN.
fn f32_is_positive(x: f32) -> bool {
    let bits = x.to_bits();
    bits & 0x8000_0000 == 0 && bits != 0 && bits <= 0x7F80_0000
}

impl Space {
    /// Whether the centre is finite and the half extent finite and positive (integer-only).
    pub(crate) fn is_valid(&self) -> bool {
        self.centre.iter().all(|&c| f32_is_finite(c))
            && f32_is_finite(self.half_extent)
            && f32_is_positive(self.half_extent)
    }

    /// Asset units → rig units (Q8.24), rounding to nearest.
    pub fn to_rig_f64(&self, p: [f64; 3]) -> Result<[i32; 3], ConvertError> {
        let mut out = [0i32; 3];
        for c in 0..3 {
            if !p[c].is_finite() {
                return Err(ConvertError::NotFinite);
            }
            let q = (p[c] - f64::from(self.centre[c])) / f64::from(self.half_extent)
                * f64::from(POS_ONE);
            if !(-2_147_483_648.0..2_147_483_647.5).contains(&q) {
                return Err(ConvertError::OutOfRange);
            }
            out[c] = i32::try_from(round_to_i64(q)).map_err(|_| ConvertError::OutOfRange)?;
        }
        Ok(out)
    }

    /// Asset units (f32) → rig units (Q8.24).
    pub fn to_rig(&self, p: [f32; 3]) -> Result<[i32; 3], ConvertError> {
        self.to_rig_f64([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])])
    }

    /// Asset units → a stored vertex rest position (Q0.15 rig units), rounding to nearest.
    /// The baker chooses the space so that the mesh fits; anything outside ±1 rig unit is
    /// [`ConvertError::OutOfRange`].
    pub fn to_rest_q15(&self, p: [f64; 3]) -> Result<[i16; 3], ConvertError> {
        let q = self.to_rig_f64(p)?;
        let mut out = [0i16; 3];
        for c in 0..3 {
            let v = (i64::from(q[c]) + (1 << (REST_SHIFT - 1))) >> REST_SHIFT;
            out[c] = i16::try_from(v).map_err(|_| ConvertError::OutOfRange)?;
        }
        Ok(out)
    }

    /// Rig units (Q8.24) → asset units, in f64.
    pub fn to_asset_f64(&self, q: [i32; 3]) -> [f64; 3] {
        let scale = f64::from(self.half_extent) / f64::from(1u32 << POS_FRAC_BITS);
        [0, 1, 2].map(|c| f64::from(self.centre[c]) + f64::from(q[c]) * scale)
    }

    /// Rig units (Q8.24) → asset units, in f32.
    pub fn to_asset(&self, q: [i32; 3]) -> [f32; 3] {
        self.to_asset_f64(q).map(|x| x as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let s = Space {
            centre: [0.0, 1.5, 0.1],
            half_extent: 0.25,
        };
        let p = [0.1, 1.6, 0.0];
        let q = s.to_rig_f64(p).unwrap();
        assert_eq!(q, [6_710_886, 6_710_886, -6_710_887]);
        let back = s.to_asset_f64(q);
        for c in 0..3 {
            assert!((back[c] - p[c]).abs() < 1e-8);
        }
        assert_eq!(
            s.to_rig_f64([f64::NAN, 0.0, 0.0]),
            Err(ConvertError::NotFinite)
        );
        assert_eq!(
            s.to_rig_f64([40.0, 0.0, 0.0]),
            Err(ConvertError::OutOfRange)
        );
        assert!(s.to_rig_f64([-31.9, 1.5, 0.1]).is_ok());
    }

    /// The integer bit tests agree with the float operations they replace, on every class of
    /// value: zeros, subnormals, normals, the extremes, infinities and NaNs of both signs.
    #[test]
    fn space_checks_on_bits_match_float_semantics() {
        let special = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            1.0,
            -1.0,
            0.25,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::from_bits(0x7F80_0001),
            f32::from_bits(0xFFFF_FFFF),
            f32::from_bits(0x7F7F_FFFF),
        ];
        // And a spread of bit patterns across the whole range.
        let mut bits = 0u32;
        let spread = (0..1 << 16).map(|_| {
            bits = bits.wrapping_mul(0x9E37_79B9).wrapping_add(0x7F4A_7C15);
            f32::from_bits(bits)
        });
        for x in special.into_iter().chain(spread) {
            assert_eq!(f32_is_finite(x), x.is_finite(), "{:#010x}", x.to_bits());
            assert_eq!(f32_is_positive(x), x > 0.0, "{:#010x}", x.to_bits());
        }
    }
}
