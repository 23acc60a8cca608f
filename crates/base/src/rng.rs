//! Deterministic random numbers for rendering.
//!
//! Every camera sample owns an independent stream: [`Rng::for_sample`] seeds a
//! PCG32 generator from a hash of (scene seed, pixel, sample index), so an
//! image does not depend on how pixels are spread over threads, and a render
//! split into sample ranges merges into exactly the image of one run.

/// A PCG32 generator (O'Neill 2014, XSH-RR output), 64-bit state.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: a bijective 64-bit mix used to derive stream seeds.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Rng {
    /// A generator with the given state seed and stream selector.
    #[inline]
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The stream of camera sample `sample` of pixel `(x, y)` under scene seed `seed`.
    #[inline]
    pub fn for_sample(seed: u64, x: u32, y: u32, sample: u32) -> Rng {
        let pixel = ((y as u64) << 32) | x as u64;
        let a = mix64(seed ^ mix64(pixel));
        let b = mix64(a ^ (sample as u64).wrapping_mul(0x9e3779b97f4a7c15));
        Rng::new(b, a)
    }

    /// The generator's raw state `(state, increment)`, for kernels that keep
    /// many generators in structure-of-arrays form.
    #[inline]
    pub fn to_parts(&self) -> (u64, u64) {
        (self.state, self.inc)
    }

    /// The generator with raw state `(state, increment)` (see [`Rng::to_parts`]).
    #[inline]
    pub fn from_parts(state: u64, inc: u64) -> Rng {
        Rng { state, inc }
    }

    /// Advances a raw state by one step; returns the same number as
    /// [`Rng::next_u32`] would. The building block of vectorised kernels.
    #[inline(always)]
    pub fn step(state: &mut u64, inc: u64) -> u32 {
        let old = *state;
        *state = old.wrapping_mul(PCG_MULT).wrapping_add(inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in `[0, 1)` from a raw state, as [`Rng::next_f32`].
    #[inline(always)]
    pub fn step_f32(state: &mut u64, inc: u64) -> f32 {
        (Rng::step(state, inc) >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform floats in `[0, 1)` from a raw state, as [`Rng::next_2d`].
    #[inline(always)]
    pub fn step_2d(state: &mut u64, inc: u64) -> glam::Vec2 {
        let x = Rng::step_f32(state, inc);
        let y = Rng::step_f32(state, inc);
        glam::Vec2::new(x, y)
    }

    /// A uniform 32-bit integer.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        Rng::step(&mut self.state, self.inc)
    }

    /// A uniform float in `[0, 1)` (24 random bits, never 1.0).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform floats in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg32_matches_reference_sequence() {
        // Reference output of pcg32_random_r with initstate 42, initseq 54
        // (pcg-c-basic's demo program).
        let mut rng = Rng::new(42, 54);
        let want = [
            0xa15c02b7u32,
            0x7b47f409,
            0xba1d3330,
            0x83d2f293,
            0xbfa4784b,
            0xcbed606e,
        ];
        for w in want {
            assert_eq!(rng.next_u32(), w);
        }
    }

    #[test]
    fn uniform_floats_have_the_right_mean_and_range() {
        let mut rng = Rng::for_sample(7, 3, 4, 5);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.next_f32();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        let mean = sum / n as f64;
        // Standard error of the mean is 1/sqrt(12 n) ≈ 6.5e-4.
        assert!((mean - 0.5).abs() < 4.0e-3, "mean {mean}");
    }

    #[test]
    fn raw_steps_draw_what_the_generator_draws() {
        let mut rng = Rng::for_sample(3, 1, 4, 1);
        let (mut state, inc) = rng.to_parts();
        for _ in 0..100 {
            assert_eq!(Rng::step_2d(&mut state, inc), rng.next_2d());
            assert_eq!(Rng::step_f32(&mut state, inc), rng.next_f32());
        }
    }

    #[test]
    fn neighbouring_samples_get_different_streams() {
        let a = Rng::for_sample(0, 0, 0, 0).next_u32();
        let b = Rng::for_sample(0, 0, 0, 1).next_u32();
        let c = Rng::for_sample(0, 1, 0, 0).next_u32();
        let d = Rng::for_sample(1, 0, 0, 0).next_u32();
        assert!(a != b && a != c && a != d && b != c);
    }
}
