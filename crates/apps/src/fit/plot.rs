//! The loss curve of a fit as a PNG: iterations on x, the loss on a log
//! scale on y, both axes labelled and ticked (a small built-in bitmap font,
//! so that no font file is needed).

use crate::error::{Error, Result};
use image::{Rgb, RgbImage};
use plsr_base::atomic_write::OutputSet;
use plsr_base::text::line;
use plsr_base::Vocabulary;
use std::io::Write;
use std::path::Path;

/// 5×7 glyphs, one byte per row (the low five bits, most significant
/// bit leftmost), for the characters the labels use.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// Draws `text` with its top-left corner at `(x, y)`; vertical text runs
/// upwards from `(x, y)` (its baseline on the left).
fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, vertical: bool) {
    let black = Rgb([0, 0, 0]);
    for (k, c) in s.chars().enumerate() {
        let Some(rows) = glyph(c) else { continue };
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                let (px, py) = if vertical {
                    (x + r as i32, y - (k as i32 * 6 + col))
                } else {
                    (x + k as i32 * 6 + col, y + r as i32)
                };
                if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                    img.put_pixel(px as u32, py as u32, black);
                }
            }
        }
    }
}

/// The loss curve (`losses[i]` after `i` iterations) as an image
/// `width × height`: y is log10 of the loss in whole decades, x the
/// iteration, both ticked and labelled.
pub fn loss_plot(losses: &[f64], width: u32, height: u32) -> RgbImage {
    let (width, height) = (width.max(200), height.max(150));
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let (l, r, t, b) = (70i32, width as i32 - 16, 14i32, height as i32 - 40);
    let positive: Vec<f64> = losses
        .iter()
        .copied()
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    let (mut lo, mut hi) = positive
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), v| {
            (a.min(v.log10()), c.max(v.log10()))
        });
    if !lo.is_finite() {
        lo = -3.0;
        hi = 0.0;
    }
    lo = lo.floor();
    hi = hi.ceil().max(lo + 1.0);
    let n = losses.len().saturating_sub(1).max(1) as f64;
    let px = |i: f64| l as f64 + i / n * (r - l) as f64;
    let py = |v: f64| b as f64 - (v - lo) / (hi - lo) * (b - t) as f64;
    let grey = Rgb([205, 205, 205]);
    let black = Rgb([0, 0, 0]);
    // y ticks every decade, labelled 1e-3 style.
    let mut d = lo;
    while d <= hi + 1e-9 {
        let y = py(d) as i32;
        line(&mut img, l, y, r, y, grey);
        line(&mut img, l - 5, y, l, y, black);
        let label = format!("1e{}", d as i32);
        text(
            &mut img,
            l - 8 - 6 * label.len() as i32,
            y - 3,
            &label,
            false,
        );
        d += 1.0;
    }
    // x ticks at round steps.
    let step = [
        1.0, 2.0, 5.0, 10.0, 20.0, 25.0, 50.0, 100.0, 200.0, 250.0, 500.0, 1000.0,
    ]
    .into_iter()
    .find(|s| n / s <= 10.0)
    .unwrap_or((n / 10.0).ceil());
    let mut i = 0.0;
    while i <= n + 1e-9 {
        let x = px(i) as i32;
        line(&mut img, x, t, x, b, grey);
        line(&mut img, x, b, x, b + 5, black);
        let label = format!("{}", i as u64);
        text(&mut img, x - 3 * label.len() as i32, b + 8, &label, false);
        i += step;
    }
    line(&mut img, l, b, r, b, black);
    line(&mut img, l, t, l, b, black);
    let xlabel = "iteration";
    text(
        &mut img,
        (l + r) / 2 - 3 * xlabel.len() as i32,
        b + 22,
        xlabel,
        false,
    );
    let ylabel = "loss (MSE)";
    text(
        &mut img,
        4,
        (t + b) / 2 + 3 * ylabel.len() as i32,
        ylabel,
        true,
    );
    // The curve.
    let blue = Rgb([30, 70, 200]);
    let mut prev: Option<(i32, i32)> = None;
    for (i, v) in losses.iter().enumerate() {
        if !(*v > 0.0 && v.is_finite()) {
            prev = None;
            continue;
        }
        let p = (px(i as f64) as i32, py(v.log10()) as i32);
        if let Some(q) = prev {
            line(&mut img, q.0, q.1, p.0, p.1, blue);
            line(&mut img, q.0, q.1 + 1, p.0, p.1 + 1, blue);
        }
        prev = Some(p);
    }
    img
}

/// Stages the loss curve as a PNG at `path` (see [`loss_plot`]).
pub fn stage_loss_plot(outputs: &mut OutputSet, path: &Path, losses: &[f64]) -> Result<()> {
    Ok(outputs.stage_png(path, &loss_plot(losses, 640, 400))?)
}

/// Stages the loss curve as CSV at `path`: `iteration,loss`, one row per
/// iteration (row `i`: the loss after `i` steps).
pub fn stage_loss_csv(outputs: &mut OutputSet, path: &Path, losses: &[f64]) -> Result<()> {
    outputs.stage(path, |w| {
        let io = |source| Error::io(path.to_path_buf(), source);
        writeln!(w, "iteration,loss").map_err(io)?;
        for (i, v) in losses.iter().enumerate() {
            writeln!(w, "{i},{v:e}").map_err(io)?;
        }
        Ok(())
    })
}
