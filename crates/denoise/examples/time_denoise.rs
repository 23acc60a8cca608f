//! Times the RT filter on a synthetic noisy image of the given size:
//! `cargo run --release -p plsr-denoise --example time_denoise -- 1920 1080`.
use plsr_denoise::{denoise, Image, Options};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (w, h) = (
        args.first().copied().unwrap_or(1920),
        args.get(1).copied().unwrap_or(1080),
    );
    let mut state = 0x9e37_79b9u32;
    let mut noise = || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32
    };
    let color: Vec<[f32; 3]> = (0..w * h)
        .map(|_| [noise() * 2.0, noise(), noise() * 0.5])
        .collect();
    let albedo = vec![[0.5f32, 0.5, 0.5]; w * h];
    let normal = vec![[0.0f32, 0.0, 1.0]; w * h];
    let image = |pixels| Image {
        pixels,
        width: w,
        height: h,
    };
    let options = Options {
        hdr: true,
        clean_aux: true,
        input_scale: None,
    };
    for _ in 0..2 {
        let t = std::time::Instant::now();
        let out = denoise(
            image(&color),
            Some(image(&albedo)),
            Some(image(&normal)),
            &options,
        )
        .unwrap();
        println!(
            "{w}×{h}: {:.2} s ({})",
            t.elapsed().as_secs_f64(),
            out[0][0]
        );
    }
}
