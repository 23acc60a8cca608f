//! Elementary functions (`exp`, `ln`, `pow`, `sin` and `cos` of a fraction
//! of a turn, `atan2`, `floor`) written as branch-free polynomials, so that a
//! loop calling them vectorises.
//!
//! `f32::exp` and friends are calls into the C library, one lane at a time:
//! a single such call in a lane loop of the vectorised kernel
//! ([`crate::integrator`]'s structure-of-arrays passes) keeps the whole loop
//! scalar. These are the Cephes library's polynomials (S. Moshier) with
//! range reduction by bit manipulation instead of `frexp`/`ldexp`, so that
//! every step is a packed instruction on AVX2: selects instead of branches
//! (bit masks where the compiler would otherwise branch, which random
//! angles mispredict in scalar code), float-to-integer tricks that need no
//! 64-bit conversion instruction, and a `floor` of our own (the baseline
//! x86-64 target's is a call).
//!
//! Accuracy, checked by this module's tests against the standard library on
//! dense grids: `exp` and `ln` within 2 ulp, `sin_cos_turns` within 3e-7
//! absolute, `exp_f64` within 2 ulp, `atan2` within 3e-7 absolute (and
//! 3 ulp) of the exact angle; `erf` within 3e-7 absolute, and `erfinv`
//! (Giles 2010) inverting it within 2e-6. Both the vectorised kernel and the
//! general integrator call these (through [`crate::bsdf`] and
//! [`crate::equirect`]), so the two
//! still give the same images to the bit.

/// `eˣ` for `f32`, within 2 ulp of `f32::exp` for `x` in `[-87.3, 88.7]`;
/// 0 below (including −∞), +∞ above, NaN for NaN.
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    // ln 2 in two parts, the first exact in few bits (Cody and Waite).
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const LO: f32 = -87.336_54;
    const HI: f32 = 88.722_83;
    let xc = x.clamp(LO, HI);
    // n = round(x / ln 2), x = n ln 2 + r with |r| ≤ ln2 / 2.
    let n = (xc * LOG2E + 0.5).floor();
    let r = xc - n * LN2_HI - n * LN2_LO;
    let r2 = r * r;
    let p = (((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2)
        * r
        + 1.666_666_5e-1)
        * r
        + 0.5)
        * r2
        + r
        + 1.0;
    // 2ⁿ from its exponent bits: n ∈ [-126, 128]; 2¹²⁸ is split in two so
    // that every factor is a normal number.
    let half = (n * 0.5).floor();
    let scale = |k: f32| f32::from_bits(((k as i32 + 127) as u32) << 23);
    let y = p * scale(half) * scale(n - half);
    if x < LO {
        0.0
    } else if x > HI {
        f32::INFINITY
    } else if x.is_nan() {
        x
    } else {
        y
    }
}

/// The natural logarithm of `x` for positive normal `x` (within 2 ulp of
/// `f32::ln`); what it returns for zero, subnormal, negative or non-finite
/// `x` is unspecified (finite garbage).
#[inline(always)]
pub fn ln(x: f32) -> f32 {
    const SQRT_HALF: f32 = std::f32::consts::FRAC_1_SQRT_2;
    let bits = x.to_bits();
    // x = m·2ᵉ with m in [½, 1).
    let e = ((bits >> 23) & 0xff) as i32 - 126;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f00_0000);
    // Centre m on 1: m in [√½, √2).
    let below = m < SQRT_HALF;
    let e = (if below { e - 1 } else { e }) as f32;
    let m = if below { m + m - 1.0 } else { m - 1.0 };
    let z = m * m;
    let mut y = ((((((((7.037_683_6e-2 * m - 1.151_461e-1) * m + 1.167_699_9e-1) * m
        - 1.242_014_1e-1)
        * m
        + 1.424_932_3e-1)
        * m
        - 1.666_805_8e-1)
        * m
        + 2.000_071_4e-1)
        * m
        - 2.499_999_4e-1)
        * m
        + 3.333_333e-1)
        * m
        * z;
    y += e * -2.121_944_4e-4;
    y -= 0.5 * z;
    m + y + e * 0.693_359_4
}

/// `xʸ` for `x ≥ 0` and finite `y`, as `exp(y ln x)`: within `2 + |y ln x|`
/// ulp or so of `f32::powf` (the logarithm's error scaled by `y`). `0ʸ` is
/// 0 for `y > 0`, +∞ for `y < 0` and 1 for `y = 0`; subnormal `x` counts
/// as 0.
#[inline(always)]
pub fn pow(x: f32, y: f32) -> f32 {
    let normal = x >= f32::MIN_POSITIVE;
    let r = exp(y * ln(if normal { x } else { 1.0 }));
    if normal {
        r
    } else if y > 0.0 {
        0.0
    } else if y < 0.0 {
        f32::INFINITY
    } else {
        1.0
    }
}

/// `(sin 2πt, cos 2πt)` for a fraction of a turn `t` (any finite value;
/// accurate to 3e-7 absolute for `|t| < 2²⁰`). Reducing in turns, not
/// radians, makes the reduction exact for the sample values `t ∈ [0, 1)`
/// that warps draw azimuths from.
#[inline(always)]
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    // The nearest quarter turn q, and the rest r in [-π/4, π/4].
    let q = floor(t * 4.0 + 0.5);
    let r = (t - q * 0.25) * std::f32::consts::TAU;
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    // Rotate by q quarter turns: (s, c) → (c, −s) → (−s, −c) → (−c, s),
    // with bit masks, not branches (random angles would mispredict them):
    // an odd quadrant swaps the pair, quadrants 2 and 3 flip both signs.
    let quadrant = q as i32 as u32;
    let swap = mask(quadrant & 1 != 0);
    let flip = (quadrant & 2) << 30;
    let sin = select(swap, c, s).to_bits() ^ flip;
    let cos = select(swap, -s, c).to_bits() ^ flip;
    (f32::from_bits(sin), f32::from_bits(cos))
}

/// `x.floor()`, to the bit (−0 and NaN included), without a call into the
/// C library: the baseline x86-64 target has no rounding instruction and
/// calls `floorf`, one lane at a time, which keeps a loop scalar.
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    // Truncated (exact below 2³¹ in magnitude), then one down if above.
    let t = x as i32 as f32;
    let t = select(mask(t > x), t - 1.0, t);
    // Magnitudes of 2²³ or more are integers already; NaN stays NaN. The
    // sign of x keeps floor(−0) = −0.
    select(mask(x.abs() < 8_388_608.0), t.copysign(x), x)
}

/// All ones where `condition` holds, else zero: a lane mask for [`select`].
#[inline(always)]
fn mask(condition: bool) -> u32 {
    0u32.wrapping_sub(condition as u32)
}

/// `a` where `mask` is all ones, `b` where it is zero, bit for bit: a
/// select the compiler cannot turn into a branch.
#[inline(always)]
fn select(mask: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// The angle of `(x, y)` in radians, in `[−π, π]`, as `f32::atan2` (within
/// 3e-7 absolute and 3 ulp of the exact angle for finite arguments, exactly 0 for
/// `(0, 0)`, ±π/2 on the y axis). Cephes' `atanf` polynomial on
/// `t = min/max(|x|, |y|) ∈ [0, 1]`, reduced to `[0, tan π/8]` by
/// `atan t = π/4 + atan((t − 1)/(t + 1))`, then placed in its octant by
/// selects.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    const TAN_PI_8: f32 = 0.414_213_57;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // t = lo/hi ∈ [0, 1], reduced above tan π/8 to (t − 1)/(t + 1) =
    // (lo − hi)/(lo + hi): one division either way.
    let reduced = mask(lo > TAN_PI_8 * hi);
    let t = select(reduced, lo - hi, lo) / select(reduced, lo + hi, hi);
    let t = select(mask(hi > 0.0), t, 0.0);
    let z = t * t;
    let a =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
    // The constants' rounding errors added back separately (Cephes'
    // "more bits"), so that π − a near the −x axis (the environment map's
    // poles) keeps the small angle's precision.
    const PI_LO: f32 = -8.742_278e-8;
    let a = select(reduced, FRAC_PI_4 + (a + 0.25 * PI_LO), a);
    // Octant: above the diagonal, from the y axis; left half, from −x;
    // the lower half by y's sign. Masks, not branches (see `sin_cos_turns`).
    let a = select(mask(ay > ax), FRAC_PI_2 + (0.5 * PI_LO - a), a);
    let a = select(mask(x.is_sign_negative()), PI + (PI_LO - a), a);
    f32::from_bits(a.to_bits() ^ (y.to_bits() & 0x8000_0000))
}

/// `eˣ` for `f64`, within 2 ulp of `f64::exp` for `x` in `[-708, 709]`; 0
/// below (including −∞), +∞ above, NaN for NaN. Cephes' rational
/// approximation; `2ⁿ` from bits with 64-bit integer adds and shifts only
/// (AVX2 has no packed `f64` to `i64` conversion).
#[inline(always)]
pub fn exp_f64(x: f64) -> f64 {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = 6.931_457_519_531_25e-1;
    const LN2_LO: f64 = 1.428_606_820_309_417_2e-6;
    const LO: f64 = -708.0;
    const HI: f64 = 709.0;
    // 1.5·2⁵²: adding it rounds to an integer held in the low mantissa bits.
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let xc = x.clamp(LO, HI);
    let n = (xc * LOG2E + 0.5).floor();
    let r = xc - n * LN2_HI - n * LN2_LO;
    let rr = r * r;
    let p = r * ((1.261_771_930_748_105_9e-4 * rr + 3.029_944_077_074_419_6e-2) * rr + 1.0);
    let q = ((3.001_985_051_386_644_5e-6 * rr + 2.524_483_403_496_841e-3) * rr
        + 2.272_655_482_081_550_3e-1)
        * rr
        + 2.0;
    let y = 1.0 + 2.0 * (p / (q - p));
    let k = ((n + MAGIC).to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64);
    let scale = f64::from_bits(((k + 1023) as u64) << 52);
    let y = y * scale;
    if x < LO {
        0.0
    } else if x > HI {
        f64::INFINITY
    } else if x.is_nan() {
        x
    } else {
        y
    }
}

/// The exponent `P(t)` of Numerical Recipes' Chebyshev fit to the
/// complementary error function, `erfc(z) = t·exp(−z² + P(t))` with
/// `t = 1/(1 + z/2)` for `z ≥ 0` (relative error < 1.2e-7, so small tails
/// keep their precision).
#[inline(always)]
pub(crate) fn erfc_fit(t: f32) -> f32 {
    -1.265_512_2
        + t * (1.000_023_7
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_204
                                + t * (1.488_515_9 + t * (-0.822_152_2 + t * 0.170_872_77))))))))
}

/// Error function, absolute error < 2e-7.
#[inline(always)]
pub fn erf(x: f32) -> f32 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t * exp(-z * z + erfc_fit(t));
    (1.0 - r).copysign(x)
}

/// The inverse error function, Giles 2010's single-precision fit (as Dr.Jit
/// computes it), with this module's vectorising logarithm; `x` in `(−1, 1)`.
#[inline(always)]
pub fn erfinv(x: f32) -> f32 {
    let w = -ln(((1.0 - x) * (1.0 + x)).max(f32::MIN_POSITIVE));
    // Both fits, then a select (a branch would keep a lane loop scalar).
    let c = w - 2.5;
    let mut p = 2.810_226_4e-8;
    p = 3.432_739_4e-7 + p * c;
    p = -3.523_387_7e-6 + p * c;
    p = -4.391_506_5e-6 + p * c;
    p = 2.185_808_7e-4 + p * c;
    p = -1.253_725e-3 + p * c;
    p = -4.177_681_6e-3 + p * c;
    p = 2.466_407_3e-1 + p * c;
    let central = 1.501_409_4 + p * c;
    let t = w.sqrt() - 3.0;
    let mut q = -2.002_142_6e-4;
    q = 1.009_505_6e-4 + q * t;
    q = 1.349_343_2e-3 + q * t;
    q = -3.673_428_4e-3 + q * t;
    q = 5.739_507_7e-3 + q * t;
    q = -7.622_461_3e-3 + q * t;
    q = 9.438_870_5e-3 + q * t;
    q = 1.001_674 + q * t;
    let tail = 2.832_976_8 + q * t;
    let p = if w < 5.0 { central } else { tail };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite `f32`s of
    /// the same sign.
    fn ulps(a: f32, b: f32) -> u32 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
    }

    #[test]
    fn exp_is_within_two_ulp_of_the_standard_library() {
        let mut worst = 0;
        let mut x = -87.3f32;
        while x < 88.7 {
            let (got, want) = (exp(x), x.exp());
            worst = worst.max(ulps(got, want));
            x += 0.000_731;
        }
        assert!(worst <= 2, "worst error {worst} ulp");
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-100.0), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert_eq!(exp(100.0), f32::INFINITY);
        assert!(exp(f32::NAN).is_nan());
    }

    #[test]
    fn ln_is_within_two_ulp_of_the_standard_library() {
        let mut worst = 0;
        // Every exponent from 2⁻¹²⁶ to 2¹²⁷, many mantissas each.
        let mut x = f32::MIN_POSITIVE;
        while x < 1e38 {
            let (got, want) = (ln(x), x.ln());
            // Near 1 the result is tiny: compare absolutely there.
            if want.abs() < 1e-3 {
                assert!((got - want).abs() <= 2.0 * f32::EPSILON * 1e-3, "ln({x})");
            } else {
                worst = worst.max(ulps(got, want));
            }
            x *= 1.000_37;
        }
        assert!(worst <= 2, "worst error {worst} ulp");
        assert_eq!(ln(1.0), 0.0);
        // The samples warps take logarithms of: 1 − u for u in [0, 1).
        for i in 0..100_000 {
            let u = i as f32 / 100_000.0;
            let (got, want) = (ln(1.0 - u), (1.0 - u).ln());
            assert!((got - want).abs() <= 2.0 * f32::EPSILON * want.abs().max(1e-3));
        }
    }

    #[test]
    fn pow_is_within_its_bound_of_the_standard_library() {
        for i in 1..=2000 {
            let x = i as f32 / 2000.0;
            for y in [0.5f32, 1.0, 2.0, 7.3, 20.0, 100.0, 1000.0, 1.0 / 101.0] {
                let (got, want) = (pow(x, y), x.powf(y));
                if want < 1e-30 {
                    assert!(got < 1.1e-30, "pow({x}, {y}) = {got}, want {want}");
                    continue;
                }
                let bound = (3.0 + (y * x.ln()).abs()) * f32::EPSILON;
                assert!(
                    ((got - want) / want).abs() <= bound,
                    "pow({x}, {y}) = {got}, want {want}"
                );
            }
        }
        assert_eq!(pow(0.0, 2.0), 0.0);
        assert_eq!(pow(0.0, 0.0), 1.0);
        assert_eq!(pow(1e-40, 3.0), 0.0);
        assert_eq!(pow(1.0, 55.0), 1.0);
    }

    #[test]
    fn floor_matches_the_standard_library_to_the_bit() {
        let mut rng = crate::rng::Rng::new(5, 0);
        let specials = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.5,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            3e9,
            -3e9,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
        ];
        let random = (0..200_000).map(|i| {
            // Every magnitude from 2⁻³⁰ to 2³⁰, both signs.
            let x = (rng.next_f32() - 0.5) * 2f32.powi(i % 61 - 30);
            if i % 2 == 0 {
                x
            } else {
                x.round() + [0.0, 0.5, -0.5, 1e-3][i as usize % 4]
            }
        });
        for x in specials.into_iter().chain(random) {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor({x})");
        }
        assert!(floor(f32::NAN).is_nan());
    }

    #[test]
    fn sin_cos_turns_matches_the_standard_library() {
        let mut worst = 0.0f64;
        for i in -200_000..=200_000 {
            let t = i as f32 / 100_000.0;
            let (s, c) = sin_cos_turns(t);
            let angle = std::f64::consts::TAU * t as f64;
            worst = worst
                .max((s as f64 - angle.sin()).abs())
                .max((c as f64 - angle.cos()).abs());
        }
        assert!(worst < 3e-7, "worst error {worst}");
        // Quarter turns are exact.
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_turns(0.5), (0.0, -1.0));
        assert_eq!(sin_cos_turns(0.75), (-1.0, -0.0));
    }

    #[test]
    fn atan2_matches_the_standard_library() {
        // Every direction on a fine circle, at several lengths (so that the
        // ratio, not the magnitude, is what the polynomial sees), and the
        // axes and diagonals exactly.
        let mut worst = (0.0f32, 0u32);
        for i in 0..200_000 {
            let angle = (i as f64 / 200_000.0 - 0.5) * std::f64::consts::TAU * 1.0001;
            for length in [1e-30f64, 1e-3, 1.0, 7.3, 1e30] {
                let (x, y) = ((angle.cos() * length) as f32, (angle.sin() * length) as f32);
                // Against the exact angle (f64), which `f32::atan2` itself
                // misses by up to 1.2e-7.
                let exact = (y as f64).atan2(x as f64);
                let got = atan2(y, x);
                let err = (got as f64 - exact).abs() as f32;
                let ulp = ulps(got.abs(), (exact as f32).abs());
                assert!(
                    err <= 3e-7 && ulp <= 3,
                    "atan2({y}, {x}) = {got}, exact {exact}"
                );
                worst.0 = worst.0.max(err);
                worst.1 = worst.1.max(ulp);
            }
        }
        for (y, x) in [
            (0.0f32, 1.0f32),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
        ] {
            assert_eq!(atan2(y, x), y.atan2(x), "atan2({y}, {x})");
        }
        assert!(worst.0 > 0.0, "the grid never left the exact cases");
    }

    #[test]
    fn exp_f64_is_within_two_ulp_of_the_standard_library() {
        let mut worst = 0u64;
        let mut x = -708.0f64;
        while x < 709.0 {
            let (got, want) = (exp_f64(x), x.exp());
            worst = worst.max((got.to_bits() as i64 - want.to_bits() as i64).unsigned_abs());
            x += 0.000_913;
        }
        assert!(worst <= 2, "worst error {worst} ulp");
        assert_eq!(exp_f64(0.0), 1.0);
        assert_eq!(exp_f64(-1000.0), 0.0);
        assert_eq!(exp_f64(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp_f64(1000.0), f64::INFINITY);
        assert!(exp_f64(f64::NAN).is_nan());
    }

    #[test]
    fn erfinv_inverts_erf() {
        for i in 1..2000 {
            let x = -1.0 + i as f64 / 1000.0;
            let y = erfinv(x as f32) as f64;
            assert!(
                (crate::filter::erf(y) - x).abs() < 2e-6 * (1.0 + x.abs()),
                "{x}: {y}"
            );
        }
        assert!((crate::filter::erf(erfinv(0.999_99) as f64) - 0.999_99).abs() < 1e-6);
    }

    #[test]
    fn erf_matches_the_series() {
        for i in 0..=600 {
            let x = -3.0 + i as f32 / 100.0;
            let want = crate::filter::erf(x as f64);
            assert!((erf(x) as f64 - want).abs() < 3e-7, "erf({x}) = {}", erf(x));
        }
    }
}
