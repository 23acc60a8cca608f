//! Colour: linear Rec.709 ↔ CIE XYZ, white points of colour temperatures,
//! and white balance by chromatic adaptation.
//!
//! plsr's colours are linear Rec.709 (sRGB primaries, D65 white). A camera's
//! white balance setting of `T` kelvin says "the scene is lit by white of
//! colour temperature `T`: make that white neutral". [`white_balance_matrix`]
//! does this with the Bradford chromatic adaptation (von Kries scaling in
//! Bradford cone space) from the white point of `T` to D65, as a 3×3 matrix
//! acting on linear Rec.709.
//!
//! The white point of a colour temperature ([`white_point_xy`]) follows the
//! CIE's and IES TM-30's reference illuminants: the Planckian locus
//! (blackbody; the cubic-spline fit of Kang et al. 2002) below 4500 K, the
//! CIE daylight locus (CIE 15:2004) above 5500 K, and a linear blend in
//! temperature between the two. So 6504 K is D65 and the matrix is the
//! identity there (to 1e-3), while incandescent and warm-white light, whose
//! white points lie on the Planckian locus, become neutral. Valid from
//! 1667 K to 25 000 K.

use glam::{DMat3, DVec2, DVec3, Mat3};

/// Lowest colour temperature accepted, kelvin.
pub const MIN_TEMPERATURE_K: f32 = 1667.0;
/// Highest colour temperature accepted, kelvin.
pub const MAX_TEMPERATURE_K: f32 = 25000.0;
/// Correlated colour temperature of D65 (the white of Rec.709), kelvin.
pub const D65_TEMPERATURE_K: f32 = 6504.0;

/// Linear Rec.709 to CIE XYZ (IEC 61966-2-1), columns are the primaries.
pub const REC709_TO_XYZ: DMat3 = DMat3::from_cols_array(&[
    0.412_456_4,
    0.212_672_9,
    0.019_333_9,
    0.357_576_1,
    0.715_152_2,
    0.119_192,
    0.180_437_5,
    0.072_175,
    0.950_304_1,
]);

/// The Bradford cone-response matrix (XYZ to sharpened LMS), row-major as published.
const BRADFORD_ROWS: [[f64; 3]; 3] = [
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
];

fn bradford() -> DMat3 {
    DMat3::from_cols_array_2d(&BRADFORD_ROWS).transpose()
}

/// CIE xy chromaticity on the Planckian (blackbody) locus at `t` kelvin,
/// 1667 K to 25 000 K (Kang et al. 2002).
pub fn planckian_xy(t: f64) -> DVec2 {
    let (t2, t3) = (t * t, t * t * t);
    let x = if t <= 4000.0 {
        -0.266_123_9e9 / t3 - 0.234_358_9e6 / t2 + 0.877_695_6e3 / t + 0.179_910
    } else {
        -3.025_846_9e9 / t3 + 2.107_037_9e6 / t2 + 0.222_634_7e3 / t + 0.240_390
    };
    let y = if t <= 2222.0 {
        -1.106_381_4 * x * x * x - 1.348_110_20 * x * x + 2.185_558_32 * x - 0.202_196_83
    } else if t <= 4000.0 {
        -0.954_947_6 * x * x * x - 1.374_185_93 * x * x + 2.091_370_15 * x - 0.167_488_67
    } else {
        3.081_758_0 * x * x * x - 5.873_386_70 * x * x + 3.751_129_97 * x - 0.370_014_83
    };
    DVec2::new(x, y)
}

/// CIE xy chromaticity of the CIE daylight illuminant of correlated colour
/// temperature `t` kelvin, 4000 K to 25 000 K (CIE 15:2004).
pub fn daylight_xy(t: f64) -> DVec2 {
    let (t2, t3) = (t * t, t * t * t);
    let x = if t <= 7000.0 {
        -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040
    };
    DVec2::new(x, -3.0 * x * x + 2.87 * x - 0.275)
}

/// White point (CIE xy) of colour temperature `t` kelvin: Planckian below
/// 4500 K, daylight above 5500 K, blended linearly in `t` in between.
pub fn white_point_xy(t: f64) -> DVec2 {
    let w = ((t - 4500.0) / 1000.0).clamp(0.0, 1.0);
    if w == 0.0 {
        planckian_xy(t)
    } else if w == 1.0 {
        daylight_xy(t)
    } else {
        planckian_xy(t).lerp(daylight_xy(t), w)
    }
}

/// CIE XYZ with `Y = 1` of chromaticity `xy`.
pub fn xy_to_xyz(xy: DVec2) -> DVec3 {
    DVec3::new(xy.x / xy.y, 1.0, (1.0 - xy.x - xy.y) / xy.y)
}

/// Linear Rec.709 of CIE XYZ.
pub fn xyz_to_rec709(xyz: DVec3) -> DVec3 {
    REC709_TO_XYZ.inverse() * xyz
}

/// The white balance for a scene lit by white of colour temperature `t`
/// kelvin (1667 to 25 000): a matrix on linear Rec.709 that maps that white
/// to neutral (equal R, G, B, luminance kept), by Bradford adaptation to D65.
pub fn white_balance_matrix(t: f32) -> Mat3 {
    let src = xy_to_xyz(white_point_xy(t as f64));
    // D65 as the Rec.709 matrix defines it: the XYZ of RGB (1, 1, 1).
    let dst = REC709_TO_XYZ * DVec3::ONE;
    let b = bradford();
    let scale = DMat3::from_diagonal((b * dst) / (b * src));
    let adapt = b.inverse() * scale * b;
    (REC709_TO_XYZ.inverse() * adapt * REC709_TO_XYZ).as_mat3()
}

/// Luminance `Y` of a linear Rec.709 RGB colour (same units as the colour).
#[inline(always)]
pub fn luminance(c: glam::Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// sRGB opto-electronic transfer function for a linear value in `[0, 1]`.
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loci_hit_known_white_points() {
        // D65 from the daylight locus at 6504 K.
        let d65 = daylight_xy(6504.0);
        assert!((d65 - DVec2::new(0.3127, 0.3290)).length() < 2e-4, "{d65}");
        // Illuminant A (2856 K blackbody): (0.4476, 0.4074).
        let a = planckian_xy(2856.0);
        assert!((a - DVec2::new(0.4476, 0.4074)).length() < 1e-3, "{a}");
        // Continuous across the blend.
        for t in [4500.0, 5500.0] {
            let l = white_point_xy(t - 0.01);
            let r = white_point_xy(t + 0.01);
            assert!((l - r).length() < 1e-5);
        }
    }

    #[test]
    fn white_balance_at_d65_is_the_identity() {
        let m = white_balance_matrix(D65_TEMPERATURE_K);
        let err = (m - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |a, x| a.max(x.abs()));
        assert!(err < 1e-3, "{m}");
    }

    #[test]
    fn white_balance_neutralises_a_warm_blackbody() {
        for t in [2700.0f32, 3200.0, 4400.0] {
            let white = xyz_to_rec709(xy_to_xyz(planckian_xy(t as f64))).as_vec3();
            assert!(white.x > 1.1 * white.z, "a warm white is reddish: {white}");
            let out = white_balance_matrix(t) * white;
            let n = out / out.y;
            assert!(
                (n - glam::Vec3::ONE).abs().max_element() < 1e-2,
                "{t} K: {n}"
            );
        }
    }
}
