//! The transfer functions between an image's values and the network's
//! input and output: OIDN's networks were trained on perceptually encoded
//! values, not on radiance.
//!
//! - HDR colour: a fit of the PU2 perceptually uniform encoding (Aydın,
//!   Mantiuk and Seidel 2008, with 1.0 meaning 100 cd/m²), scaled so that
//!   65504 (the largest half float) maps to 1.
//! - LDR colour: the sRGB curve.
//! - Albedo and normal (already in [0, 1] once mapped): none.

/// The PU curve's coefficients and the ends of its three pieces: linear
/// below `Y0`, a power law up to `Y1`, logarithmic above.
const A: f32 = 1.412_837_6e3;
const B: f32 = 1.645_931_7;
const C: f32 = 4.313_849_8e-1;
const D: f32 = -2.941_396e-3;
const E: f32 = 1.926_532_5e-1;
const F: f32 = 6.260_261e-3;
const G: f32 = 9.986_201_5e-1;
const Y0: f32 = 1.579_457_6e-6;
const Y1: f32 = 3.220_876_3e-2;
const X0: f32 = 2.231_517e-3;
const X1: f32 = 3.709_747_5e-1;

/// PU(65504): the encoding is divided by it, so the largest half float
/// encodes to 1.
const PU_OF_HALF_MAX: f32 = 3.135_119;

/// How values are encoded for the network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transfer {
    /// Values as they are.
    Linear,
    /// The sRGB curve (LDR images).
    Srgb,
    /// The normalised PU curve (HDR images).
    Pu,
}

impl Transfer {
    /// Encodes a linear value (≥ 0).
    pub fn forward(self, y: f32) -> f32 {
        match self {
            Transfer::Linear => y,
            Transfer::Srgb => {
                if y <= 0.003_130_8 {
                    12.92 * y
                } else {
                    1.055 * y.powf(1.0 / 2.4) - 0.055
                }
            }
            Transfer::Pu => pu(y) / PU_OF_HALF_MAX,
        }
    }

    /// Decodes a network value (≥ 0) back to a linear one.
    pub fn inverse(self, x: f32) -> f32 {
        match self {
            Transfer::Linear => x,
            Transfer::Srgb => {
                if x <= 0.040_45 {
                    x / 12.92
                } else {
                    ((x + 0.055) / 1.055).powf(2.4)
                }
            }
            Transfer::Pu => pu_inverse(x * PU_OF_HALF_MAX),
        }
    }
}

/// The PU curve, unnormalised.
fn pu(y: f32) -> f32 {
    if y <= Y0 {
        A * y
    } else if y <= Y1 {
        B * y.powf(C) + D
    } else {
        E * (y + F).ln() + G
    }
}

/// The PU curve's inverse, unnormalised.
fn pu_inverse(x: f32) -> f32 {
    if x <= X0 {
        x / A
    } else if x <= X1 {
        ((x - D) / B).powf(1.0 / C)
    } else {
        ((x - G) / E).exp() - F
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pu_curve_is_continuous_and_its_inverse_inverts_it() {
        // The pieces meet where the constants say.
        assert!((pu(Y0) - X0).abs() < 1e-6, "{} vs {X0}", pu(Y0));
        assert!((pu(Y1) - X1).abs() < 1e-5, "{} vs {X1}", pu(Y1));
        assert!((B * Y0.powf(C) + D - A * Y0).abs() < 1e-5);
        assert!((E * (Y1 + F).ln() + G - (B * Y1.powf(C) + D)).abs() < 1e-4);
        // The largest half float encodes to 1.
        assert!((Transfer::Pu.forward(65504.0) - 1.0).abs() < 1e-6);
        // Round trips over twelve decades, to float precision.
        let mut y = 1e-8f32;
        while y < 1e4 {
            for t in [Transfer::Pu, Transfer::Srgb, Transfer::Linear] {
                let back = t.inverse(t.forward(y));
                assert!((back - y).abs() <= 2e-4 * y + 1e-9, "{t:?}: {y} → {back}");
            }
            y *= 1.37;
        }
        // Monotonic.
        let mut last = -1.0;
        for i in 0..10_000 {
            let x = Transfer::Pu.forward(i as f32 * 0.01);
            assert!(x > last);
            last = x;
        }
    }

    #[test]
    fn srgb_is_the_standard_curve() {
        assert_eq!(Transfer::Srgb.forward(0.0), 0.0);
        assert!((Transfer::Srgb.forward(1.0) - 1.0).abs() < 1e-6);
        assert!((Transfer::Srgb.forward(0.18) - 0.461_356).abs() < 1e-5);
        assert!((Transfer::Srgb.inverse(0.5) - 0.214_041).abs() < 1e-5);
    }
}
