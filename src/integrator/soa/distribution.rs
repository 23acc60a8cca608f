//! Microfacet distributions known to the compiler ([`Ggx`], [`Beckmann`]),
//! for the rough Cook–Torrance and rough dielectric lanes.

use super::*;

/// A microfacet distribution's kind known to the compiler ([`Ggx`] or
/// [`Beckmann`]), so that a lane loop has no branch on it.
pub(super) trait LaneDistribution: Copy + PartialEq + std::fmt::Debug {
    /// The distribution.
    const KIND: Distribution;
}

/// Trowbridge–Reitz (GGX) microfacets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Ggx;

impl LaneDistribution for Ggx {
    const KIND: Distribution = Distribution::Ggx;
}

/// Beckmann microfacets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Beckmann;

impl LaneDistribution for Beckmann {
    const KIND: Distribution = Distribution::Beckmann;
}
