//! Transforms act on a light's parameters (paper eq. 15–21), not on its
//! tessellated vertices.

use super::{Pls, PlsGeometry, PlsLighting};
use glam::{Mat3, Mat4};

impl Pls {
    /// The light transformed by the affine 4×4 `m = [R T; 0 1]`, acting on
    /// the parameters (eq. 15–21): `n' = normalize(R·n)`, `e1' = M·e1`,
    /// `e2' = M·e2`, α unchanged, `d' = s·d` with
    /// `s = |R·(v × n)| / |v × n|`; `a`, `c`, `b` unchanged.
    ///
    /// For rotations, translations and uniform scales this equals transforming
    /// the tessellated mesh; for shears and non-uniform scales it is an
    /// approximation (the outline stays symmetric), measured in the tests.
    pub fn transform(&self, m: &Mat4) -> Pls {
        let r = Mat3::from_mat4(*m);
        let n = self.normal();
        let v = self.g.e2 - self.g.e1;
        let vxn = v.cross(n);
        let s = (r * vxn).length() / vxn.length();
        Pls {
            name: self.name.clone(),
            n: (r * n).normalize(),
            g: PlsGeometry {
                e1: m.transform_point3(self.g.e1),
                e2: m.transform_point3(self.g.e2),
                alpha1: self.g.alpha1,
                alpha2: self.g.alpha2,
                d: self.g.d.map(|d| d * s),
            },
            a_deg: self.a_deg,
            penumbra_deg: self.penumbra_deg,
            c: self.c,
            b: self.b,
        }
    }
}

impl PlsLighting {
    /// Transforms every light (see [`Pls::transform`]).
    pub fn transform(&self, m: &Mat4) -> PlsLighting {
        PlsLighting {
            mode: self.mode,
            lights: self.lights.iter().map(|l| l.transform(m)).collect(),
        }
    }
}
