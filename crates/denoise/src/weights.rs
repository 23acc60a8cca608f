//! OIDN's trained weights, shipped in plsr (`assets/oidn/`, Apache-2.0,
//! unmodified), and which set a filter uses for the images it is given.

use crate::transfer::Transfer;

/// What the filter is given besides the colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Guides {
    /// The colour alone.
    None,
    /// The albedo of the first non-specular hit.
    Albedo,
    /// Albedo and normal, each noisy (as rendered) or clean (noise-free, or
    /// prefiltered).
    AlbedoNormal {
        /// Whether both are clean.
        clean: bool,
    },
}

/// A set of weights: its name (OIDN's) and its archive.
#[derive(Debug, Clone, Copy)]
pub struct WeightSet {
    /// OIDN's name for it (`rt_hdr_alb_nrm`).
    pub name: &'static str,
    /// The TZA archive.
    pub bytes: &'static [u8],
}

macro_rules! weights {
    ($name:literal) => {
        WeightSet {
            name: $name,
            bytes: include_bytes!(concat!("../../../assets/oidn/", $name, ".tza")),
        }
    };
}

/// The weights of the RT filter for an image of colour (`hdr` or LDR)
/// with `guides`.
pub fn for_color(hdr: bool, guides: Guides) -> WeightSet {
    match (hdr, guides) {
        (true, Guides::None) => weights!("rt_hdr"),
        (true, Guides::Albedo) => weights!("rt_hdr_alb"),
        (true, Guides::AlbedoNormal { clean: false }) => weights!("rt_hdr_alb_nrm"),
        (true, Guides::AlbedoNormal { clean: true }) => weights!("rt_hdr_calb_cnrm"),
        (false, Guides::None) => weights!("rt_ldr"),
        (false, Guides::Albedo) => weights!("rt_ldr_alb"),
        (false, Guides::AlbedoNormal { clean: false }) => weights!("rt_ldr_alb_nrm"),
        (false, Guides::AlbedoNormal { clean: true }) => weights!("rt_ldr_calb_cnrm"),
    }
}

/// The weights that prefilter a noisy albedo layer.
pub fn albedo_prefilter() -> WeightSet {
    weights!("rt_alb")
}

/// The weights that prefilter a noisy normal layer.
pub fn normal_prefilter() -> WeightSet {
    weights!("rt_nrm")
}

/// How the colour is encoded for weights of a filter of `hdr` colour.
pub fn color_transfer(hdr: bool) -> Transfer {
    if hdr {
        Transfer::Pu
    } else {
        Transfer::Srgb
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tza::{Archive, Element};

    /// Every shipped set is OIDN's base U-Net with the input channels its
    /// guides give: 32 tensors, 3 × 3 kernels, a 3-channel output.
    #[test]
    fn every_weight_set_is_the_u_net_its_inputs_need() {
        let mut sets = Vec::new();
        for hdr in [true, false] {
            for (guides, channels) in [
                (Guides::None, 3),
                (Guides::Albedo, 6),
                (Guides::AlbedoNormal { clean: false }, 9),
                (Guides::AlbedoNormal { clean: true }, 9),
            ] {
                sets.push((for_color(hdr, guides), channels));
            }
        }
        sets.push((albedo_prefilter(), 3));
        sets.push((normal_prefilter(), 3));
        for (set, channels) in sets {
            let a = Archive::parse(set.bytes).unwrap_or_else(|e| panic!("{}: {e}", set.name));
            assert_eq!(a.names().len(), 32, "{}", set.name);
            let first = a.tensor("enc_conv0.weight").unwrap();
            assert_eq!(first.dims, [32, channels, 3, 3], "{}", set.name);
            assert_eq!(first.element, Element::Half);
            let skip = a.tensor("dec_conv1a.weight").unwrap();
            assert_eq!(skip.dims, [64, 64 + channels, 3, 3], "{}", set.name);
            assert_eq!(a.tensor("dec_conv0.weight").unwrap().dims, [3, 32, 3, 3]);
            let bias = a.values("dec_conv0.bias").unwrap();
            assert!(bias.iter().all(|b| b.is_finite()), "{}", set.name);
        }
    }
}
