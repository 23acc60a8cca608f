//! `plsr bench denoise`: plsr's denoiser against Intel Open Image Denoise
//! (PyPI's `pyoidn`, OIDN's own CPU build) on the same noisy 1920×1080
//! render with the same guides and threads, in one run: each one's time
//! (best of two after a warm-up; both include loading the weights), their
//! ratio, and how far apart their outputs are (tone-mapped PSNR). Then the
//! peak memory of denoising an 8192×4096 panorama (colour alone, as a
//! merged panorama has no guides), measured in a child process of this
//! binary so that nothing else counts.

use crate::error::{Error, Result};
use plsr::film::denoise::DenoiseSettings;
use plsr::film::Film;
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Options of `plsr bench denoise`.
pub struct DenoiseBenchOptions {
    /// Worker threads of both denoisers (default: all cores).
    pub threads: Option<usize>,
    /// The Python with `pyoidn` (`None`: plsr alone).
    pub python: Option<PathBuf>,
    /// The render's size.
    pub size: (usize, usize),
    /// The panorama's size for the memory measurement (`None`: skipped).
    pub panorama: Option<(usize, usize)>,
    /// Run only the memory probe at this size (the child process).
    pub probe: Option<(usize, usize)>,
}

/// The Cornell box at `w × h` (the image is wider than the box: the sides
/// see nothing, as a frame's background does), 8 spp.
fn scene(obj: &Path, w: usize, h: usize) -> String {
    format!(
        "[render]\nspp = 8\nmax_depth = 8\nseed = 0\n\n\
         [camera]\ntype = \"pinhole\"\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\n\
         up = [0, 1, 0]\nvfov = 37\nresolution = [{w}, {h}]\n\n\
         [[shapes]]\ntype = \"obj\"\nname = \"cornell box\"\nfile = \"{}\"\n",
        obj.display().to_string().replace('\\', "/")
    )
}

fn write_raw(path: &Path, pixels: &[[f32; 3]]) -> Result<()> {
    let bytes: Vec<u8> = pixels
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(path, bytes).map_err(|source| Error::io(path, source))
}

fn read_raw(path: &Path, n: usize) -> Result<Vec<[f32; 3]>> {
    let bytes = std::fs::read(path).map_err(|source| Error::io(path, source))?;
    if bytes.len() != n * 12 {
        return Err(Error::input(
            path,
            "",
            format!("{} bytes, not {n} RGB float pixels", bytes.len()),
        ));
    }
    Ok(bytes
        .chunks_exact(12)
        .map(|b| {
            let f = |i: usize| f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
            [f(0), f(4), f(8)]
        })
        .collect())
}

/// PSNR (dB) of two HDR images after the tone map x / (1 + x) and a 2.2
/// gamma, as the denoiser's parity tests compare them.
fn psnr_tonemapped(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let tone = |v: f32| (f64::from(v.max(0.0)) / (1.0 + f64::from(v.max(0.0)))).powf(1.0 / 2.2);
    let mse = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| (tone(p[c]) - tone(q[c])).powi(2)))
        .sum::<f64>()
        / (a.len() * 3) as f64;
    10.0 * (1.0 / mse.max(1e-30)).log10()
}

/// Runs `plsr bench denoise`.
pub fn run(o: &DenoiseBenchOptions) -> Result<()> {
    if let Some((w, h)) = o.probe {
        return probe(w, h);
    }
    let (w, h) = o.size;
    let dir = super::bench_dir("denoise")?;
    let obj = std::fs::canonicalize("assets/scenes/cornell/cornell.obj")
        .map_err(|source| Error::io("assets/scenes/cornell/cornell.obj", source))?;
    let scene_path = dir.join("cornell.toml");
    std::fs::write(&scene_path, scene(&obj, w, h))
        .map_err(|source| Error::io(scene_path.clone(), source))?;
    let noisy_path = dir.join("noisy.exr");
    let exe = std::env::current_exe().map_err(|source| Error::io("plsr", source))?;
    let mut render = Command::new(&exe);
    render
        .arg("render")
        .arg(&scene_path)
        .arg("-o")
        .arg(&noisy_path)
        .arg("-q");
    if let Some(t) = o.threads {
        render.args(["--threads", &t.to_string()]);
    }
    let out = render
        .output()
        .map_err(|source| Error::io(exe.clone(), source))?;
    if !out.status.success() {
        return Err(Error::invalid_argument(format!(
            "plsr render: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let film = Film::read_exr(&noisy_path)?;
    let threads = o.threads.unwrap_or_else(plsr_base::threads::max_threads);
    println!("plsr bench denoise: the Cornell box at {w}×{h}, 8 spp, colour + albedo + normal, HDR, {threads} threads");

    // plsr, in this process: a warm-up, then the best of two.
    let pool = plsr_base::threads::thread_pool(o.threads)?;
    let settings = DenoiseSettings::default();
    let mut times = Vec::new();
    let mut denoised = film.clone();
    for i in 0..3 {
        let mut f = film.clone();
        let start = Instant::now();
        pool.install(|| f.denoise(&settings))?;
        let seconds = start.elapsed().as_secs_f64();
        println!("  plsr run {}: {seconds:.2} s", i + 1);
        if i > 0 {
            times.push(seconds);
        }
        denoised = f;
    }
    let plsr_best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let ours: Vec<[f32; 3]> = denoised.color.iter().map(|c| c.to_array()).collect();

    // OIDN, on the same guides.
    let oidn = match &o.python {
        None => Err("--no-peer".to_string()),
        Some(py) => run_oidn(py, &dir, &film, &settings, o.threads),
    };
    println!();
    println!("| denoiser | {w}×{h} best (s) | runs (s) | ratio to OIDN |");
    println!("|---|---|---|---|");
    let list = |t: &[f64]| {
        t.iter()
            .map(|s| format!("{s:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match &oidn {
        Ok(OidnRun {
            version,
            output: theirs,
            times: their_times,
        }) => {
            let best = their_times.iter().copied().fold(f64::INFINITY, f64::min);
            let ratio = plsr_best / best;
            println!("| plsr | {plsr_best:.2} | {} | {ratio:.2}× |", list(&times));
            println!(
                "| OIDN {version} (pyoidn) | {best:.2} | {} | 1 |",
                list(their_times)
            );
            println!();
            println!(
                "plsr takes {ratio:.2}× OIDN's time (target ≤ 2×: {}); outputs agree to {:.1} dB PSNR (tone-mapped; target ≥ 45 dB)",
                if ratio <= 2.0 { "met" } else { "NOT met" },
                psnr_tonemapped(&ours, theirs)
            );
        }
        Err(why) => {
            println!("| plsr | {plsr_best:.2} | {} | - |", list(&times));
            println!();
            println!("OIDN: not measured ({why}); install it with `pip install pyoidn numpy` and pass --python");
        }
    }

    if let Some((pw, ph)) = o.panorama {
        println!();
        let mut probe = Command::new(&exe);
        probe.args(["bench", "denoise", "--denoise-probe", &format!("{pw},{ph}")]);
        if let Some(t) = o.threads {
            probe.args(["--threads", &t.to_string()]);
        }
        let out = probe
            .output()
            .map_err(|source| Error::io(exe.clone(), source))?;
        let text = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            return Err(Error::invalid_argument(format!(
                "the memory probe failed: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            )));
        }
        print!("{text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// OIDN's version, output and times.
struct OidnRun {
    version: String,
    output: Vec<[f32; 3]>,
    times: Vec<f64>,
}

/// OIDN's run (`scripts/bench_denoise_oidn.py`), or why not.
fn run_oidn(
    python: &Path,
    dir: &Path,
    film: &Film,
    settings: &DenoiseSettings,
    threads: Option<usize>,
) -> std::result::Result<OidnRun, String> {
    let guides = film.denoise_guides(settings);
    let write = |name: &str, pixels: &[[f32; 3]]| -> std::result::Result<PathBuf, String> {
        let path = dir.join(name);
        write_raw(&path, pixels).map_err(|e| e.to_string())?;
        Ok(path)
    };
    let mut cmd = Command::new(python);
    cmd.arg("scripts/bench_denoise_oidn.py")
        .arg(film.width.to_string())
        .arg(film.height.to_string())
        .arg(write("color.f32", &guides.color)?);
    if let (Some(a), Some(n)) = (&guides.albedo, &guides.normal) {
        cmd.arg(write("albedo.f32", a)?)
            .arg(write("normal.f32", n)?);
    }
    let output = dir.join("oidn.f32");
    cmd.arg("--output").arg(&output);
    if let Some(t) = threads {
        cmd.arg("--threads").arg(t.to_string());
    }
    let (v, line) = super::python_json(&mut cmd, python)?;
    let times: Vec<f64> = v["seconds"]
        .as_array()
        .ok_or(format!("no seconds in {line}"))?
        .iter()
        .filter_map(|s| s.as_f64())
        .collect();
    let theirs = read_raw(&output, guides.color.len()).map_err(|e| e.to_string())?;
    let version = v["oidn"].as_str().unwrap_or("?").to_string();
    Ok(OidnRun {
        version,
        output: theirs,
        times,
    })
}

/// The child process of the memory measurement: denoises a noisy `w × h`
/// colour-only image and prints its time and the peak memory.
fn probe(w: usize, h: usize) -> Result<()> {
    let mut state = 0x9e37_79b9u32;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32
    };
    let color: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let sky = 0.3 + (i / w) as f32 / h as f32;
            [sky * next() * 2.0, sky * next() * 2.0, sky * next() * 2.5]
        })
        .collect();
    let input_mib = (w * h * 12) as f64 / (1u64 << 20) as f64;
    let before = plsr_base::memory::peak_bytes().unwrap_or(0);
    let start = Instant::now();
    let out = plsr_denoise::denoise(
        plsr_denoise::Image {
            pixels: &color,
            width: w,
            height: h,
        },
        None,
        None,
        &plsr_denoise::Options {
            hdr: true,
            clean_aux: false,
            input_scale: None,
        },
    )
    .map_err(|e| Error::invalid_argument(e.to_string()))?;
    let seconds = start.elapsed().as_secs_f64();
    let peak = plsr_base::memory::peak_bytes().unwrap_or(0);
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    println!(
        "{w}×{h} panorama, colour alone: denoised in {seconds:.1} s; peak memory {:.0} MiB \
         (the image in and out: {:.0} MiB; before denoising: {:.0} MiB); target < 2048 MiB: {}",
        mib(peak),
        2.0 * input_mib,
        mib(before),
        if mib(peak) < 2048.0 { "met" } else { "NOT met" }
    );
    drop(out);
    Ok(())
}
