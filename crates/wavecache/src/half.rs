//! Half-precision (IEEE 754 binary16) storage of wavelet coefficients (paper Sec. 6: "we stored
//! the coefficients as half-precision floats"). An in-house conversion (round to nearest even,
//! subnormals, ±inf for overflow) so the crate needs no extra dependency.

/// f32 → f16 bits, round to nearest even.
pub fn f32_to_f16(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 0xff {
        // inf or NaN (keep a quiet NaN bit).
        return sign | 0x7c00 | if man != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        // Subnormal: shift the mantissa with its implicit bit.
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let half = m >> shift;
        let rem = m & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let round = rem > halfway || (rem == halfway && half & 1 == 1);
        return sign | (half + round as u32) as u16;
    }
    let half = ((e as u32) << 10) | (man >> 13);
    let rem = man & 0x1fff;
    let round = rem > 0x1000 || (rem == 0x1000 && half & 1 == 1);
    // A carry out of the mantissa correctly bumps the exponent (up to inf).
    sign | (half + round as u32) as u16
}

/// f16 bits → f32 (exact).
#[inline]
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h & 0x8000) as u32) << 16;
    let exp = ((h >> 10) & 0x1f) as u32;
    let man = (h & 0x3ff) as u32;
    let bits = if exp == 0 {
        if man == 0 {
            sign
        } else {
            // Subnormal: value = man × 2^-24.
            return f32::from_bits(sign) + (if sign != 0 { -1.0 } else { 1.0 }) * man as f32 * (1.0 / 16_777_216.0);
        }
    } else if exp == 0x1f {
        sign | 0x7f80_0000 | (man << 13)
    } else {
        sign | ((exp + 127 - 15) << 23) | (man << 13)
    };
    f32::from_bits(bits)
}

/// f16 bits → f32 for finite values (what [`crate::haar`] stores: the packer clamps to
/// ±[`F16_MAX`]): one shift and one multiply by 2^112, exact for normals and subnormals.
#[inline(always)]
pub fn f16_to_f32_finite(h: u16) -> f32 {
    let magnitude = f32::from_bits(((h & 0x7fff) as u32) << 13) * f32::from_bits(0x7780_0000);
    f32::from_bits(magnitude.to_bits() | (((h & 0x8000) as u32) << 16))
}

/// f32 → f16 bits, clamped to the finite range.
pub fn f32_to_f16_finite(x: f32) -> u16 {
    f32_to_f16(x.clamp(-F16_MAX, F16_MAX))
}

/// Largest finite f16.
pub const F16_MAX: f32 = 65504.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_rounding() {
        for x in [0.0f32, 1.0, -2.5, 0.1, 65504.0, 6.1035156e-5, 5.96e-8, 1e-3, 3.5, -1234.5] {
            let y = f16_to_f32(f32_to_f16(x));
            let rel = if x != 0.0 { ((y - x) / x).abs() } else { y.abs() };
            println!("{x} -> {y} (rel {rel:.2e})");
            assert!(rel <= 4.9e-4 || (x.abs() < 6.2e-5 && (y - x).abs() < 6e-8), "{x} -> {y}");
        }
        assert_eq!(f32_to_f16(1e6), 0x7c00);
        assert!(f16_to_f32(f32_to_f16(f32::NAN)).is_nan());
        // Every f16 converts back to itself; the fast decoder agrees on every finite value.
        for h in 0..=0xffffu16 {
            let x = f16_to_f32(h);
            if !x.is_nan() {
                assert_eq!(f32_to_f16(x), h, "{h:#x} {x}");
            }
            if x.is_finite() {
                assert_eq!(f16_to_f32_finite(h).to_bits(), x.to_bits(), "{h:#x}");
            }
        }
        assert_eq!(f32_to_f16_finite(1e9), f32_to_f16(F16_MAX));
    }
}
