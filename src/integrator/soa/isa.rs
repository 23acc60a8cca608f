//! The instruction sets the kernel is compiled for, chosen at run time
//! ([`Isa`], [`trace_pass`]), and the same choice as a type for the
//! shading passes ([`InstructionSet`]).

use super::*;

/// An instruction set the vectorised kernel is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64): 4 lanes per instruction.
    Baseline,
    /// AVX2 (x86-64): 8 lanes per instruction.
    Avx2,
    /// AVX-512 F/DQ/VL/BW (x86-64): 16 lanes per instruction.
    Avx512,
}

impl Isa {
    /// Whether this CPU can run the kernel compiled for `self`.
    pub fn is_available(self) -> bool {
        match self {
            Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                is_x86_feature_detected!("avx2")
                    && is_x86_feature_detected!("fma")
                    && is_x86_feature_detected!("avx512f")
                    && is_x86_feature_detected!("avx512dq")
                    && is_x86_feature_detected!("avx512vl")
                    && is_x86_feature_detected!("avx512bw")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The best instruction set this CPU has.
    pub fn best() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|isa| isa.is_available())
            .unwrap_or(Isa::Baseline)
    }

    /// Its name, as `plsr render` reports it.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "AVX2",
            Isa::Avx512 => "AVX-512",
        }
    }
}

/// Renders sample `pass.sample` of every pixel of `pass.tile`, as
/// the general integrator does. The whole pass is compiled
/// for AVX-512, for AVX2 and for the baseline instruction set; `isa` picks
/// one, or the baseline where the CPU lacks it. Every variant gives the same
/// result: no instruction set changes how an operation rounds, and Rust
/// fuses no multiply-add by itself. With `pair`, the pass renders
/// compositing's pair of renders (see [`PairPass`]).
pub fn trace_pass(
    isa: Isa,
    pass: &TilePass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
    pair: Option<PairPass>,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if isa == Isa::Avx512 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx512` is
            // compiled for (checked just above).
            return unsafe { trace_pass_avx512(pass, lanes, pixels, stats, pair) };
        }
        if isa == Isa::Avx2 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx2` is compiled
            // for (checked just above).
            return unsafe { trace_pass_avx2(pass, lanes, pixels, stats, pair) };
        }
    }
    let _ = isa;
    trace_pass_body::<Baseline>(pass, lanes, pixels, stats, pair)
}

/// [`trace_pass_body`] compiled for AVX-512 (16 lanes per instruction).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
pub(super) unsafe fn trace_pass_avx512(
    pass: &TilePass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
    pair: Option<PairPass>,
) {
    trace_pass_body::<Avx512>(pass, lanes, pixels, stats, pair)
}

/// [`trace_pass_body`] compiled for AVX2 (8 lanes per instruction). `fma`
/// only makes the instructions available: Rust never fuses `a·b + c` itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn trace_pass_avx2(
    pass: &TilePass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
    pair: Option<PairPass>,
) {
    trace_pass_body::<Avx2>(pass, lanes, pixels, stats, pair)
}

/// An instruction set the kernel's passes are compiled for, as a type: each
/// variant of [`trace_pass`] calls the kinds' passes compiled for its own
/// set (a function that is not inlined does not inherit its caller's target
/// features).
pub(super) trait InstructionSet {
    /// [`shade_chunks`] of `pass` with these parameters, in a function of
    /// its own compiled for this instruction set.
    fn pass<P: MaterialPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    );
}

/// The baseline instruction set (every x86-64 CPU, or another architecture).
pub(super) struct Baseline;

impl InstructionSet for Baseline {
    #[inline(always)]
    fn pass<P: MaterialPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        material_pass_baseline::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
    }
}

/// AVX2 with FMA; only [`trace_pass_avx2`] uses it.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx2;

#[cfg(target_arch = "x86_64")]
impl InstructionSet for Avx2 {
    #[inline(always)]
    fn pass<P: MaterialPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        // SAFETY: only `trace_pass_avx2` passes this type, and `trace_pass`
        // calls that only on a CPU with AVX2 and FMA.
        unsafe { material_pass_avx2::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u) }
    }
}

/// AVX-512 (F, DQ, VL, BW); only [`trace_pass_avx512`] uses it.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx512;

#[cfg(target_arch = "x86_64")]
impl InstructionSet for Avx512 {
    #[inline(always)]
    fn pass<P: MaterialPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        // SAFETY: only `trace_pass_avx512` passes this type, and
        // `trace_pass` calls that only on a CPU with these features.
        unsafe { material_pass_avx512::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u) }
    }
}

/// A pass for the baseline instruction set.
#[inline(never)]
pub(super) fn material_pass_baseline<
    P: MaterialPass,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}

/// A pass compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
pub(super) unsafe fn material_pass_avx2<
    P: MaterialPass,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}

/// A pass compiled for AVX-512.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
#[inline(never)]
pub(super) unsafe fn material_pass_avx512<
    P: MaterialPass,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}
