//! A parametric light as a scene holds it: its parameters, how its
//! brightness reads, and how finely its outline is tessellated. The built
//! scene keeps these beside the triangles Embree traces, so that later
//! stages (transforms, re-tessellation, fitting) work on the parameters.

use super::{BrightnessMode, Cone, Pls, PlsError, PlsMesh};
use glam::Vec3;

/// The most quads a light's outline may be tessellated into.
pub const MAX_NF: u32 = 4096;

/// Checks a tessellation count: 1 to [`MAX_NF`] quads along the axis. The
/// one check of Nf that scene files, the command line and the C ABI share;
/// the error says what is wrong.
pub fn check_nf(nf: u64) -> Result<u32, NfOutOfRange> {
    if (1..=MAX_NF as u64).contains(&nf) {
        Ok(nf as u32)
    } else {
        Err(NfOutOfRange(nf))
    }
}

/// A tessellation count outside 1 to [`MAX_NF`]. Its text does not name
/// the option or field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("must be between 1 and {MAX_NF}, got {0}")]
pub struct NfOutOfRange(pub u64);

/// One parametric light in a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct PlsEmitter {
    /// The light's parameters `(n, g, a, c, b)`.
    pub light: Pls,
    /// How `b` becomes radiance.
    pub mode: BrightnessMode,
    /// Quads along the axis of the tessellated outline, 1 to [`MAX_NF`].
    pub nf: u32,
}

impl PlsEmitter {
    /// A checked emitter: the light's parameters valid and `nf` in range.
    pub fn new(light: Pls, mode: BrightnessMode, nf: u32) -> Result<PlsEmitter, PlsError> {
        light.validate(0)?;
        check_nf(nf as u64).map_err(|message| PlsError {
            light: light.label(0),
            parameter: "nf".into(),
            message: message.to_string(),
        })?;
        Ok(PlsEmitter { light, mode, nf })
    }

    /// The outline tessellated into `nf` quads.
    pub fn tessellate(&self) -> PlsMesh {
        self.light.tessellate(self.nf)
    }

    /// The window: the cone the light emits into (paper eq. 12, or eq. 12′
    /// with a soft edge).
    pub fn cone(&self) -> Cone {
        Cone::with_penumbra(
            self.light.normal(),
            self.light.a_deg,
            self.light.penumbra_deg,
        )
    }

    /// Surface radiance of the tessellated emitter of area `area` (m²).
    pub fn radiance(&self, area: f32) -> Vec3 {
        self.light.radiance(self.mode, area)
    }
}
