//! The command line's one spelling of image sizes and rectangles:
//! - a size is `W,H` (`render --resolution 1920,1080`, `hdr capture --size
//!   512,256`);
//! - a rectangle is its corners `X0,Y0,X1,Y1`: columns `X0..X1` and rows
//!   `Y0..Y1`, the second corner excluded (`render --crop`, `compare
//!   --crop`, the windows of `hdr merge --grey-card`).
//!
//! The other spellings (`WxH`; an origin and a size `X,Y,WxH`) are refused
//! with the right one.

use crate::error::{Error, Result};
use plsr_base::Vocabulary;

/// Parses `flag`'s size `W,H`, each from 1 to `max` pixels.
pub fn parse_size(flag: &str, s: &str, max: u32) -> Result<(u32, u32)> {
    let bad = |why: String| Error::invalid_argument(format!("{flag} {s}: {why}"));
    let number = |x: &str| x.trim().parse::<u32>().ok();
    if let Some((w, h)) = s.split_once(['x', 'X']) {
        if let (Some(w), Some(h)) = (number(w), number(h)) {
            return Err(bad(format!(
                "sizes are written W,H in plsr: {flag} {w},{h}"
            )));
        }
    }
    let (w, h) = match s.split(',').collect::<Vec<_>>()[..] {
        [w, h] => (w, h),
        _ => return Err(bad("expected W,H, e.g. 1920,1080".into())),
    };
    let within = |x: &str| {
        number(x)
            .filter(|v| (1..=max).contains(v))
            .ok_or_else(|| bad(format!("{x:?} is not a size from 1 to {max} pixels")))
    };
    Ok((within(w)?, within(h)?))
}

/// Parses `flag`'s rectangle `X0,Y0,X1,Y1` (corners, `X0 < X1`, `Y0 <
/// Y1`); `within`: the image it must lie in, when known.
pub fn parse_rect(flag: &str, s: &str, within: Option<(u32, u32)>) -> Result<[u32; 4]> {
    parse_rect_before(flag, s, "", within)
}

/// [`parse_rect`] of a rectangle that the argument follows with `rest`
/// (`=100` of `--known-luminance X0,Y0,X1,Y1=100`), which the messages
/// keep.
pub fn parse_rect_before(
    flag: &str,
    s: &str,
    rest: &str,
    within: Option<(u32, u32)>,
) -> Result<[u32; 4]> {
    let bad = |why: String| Error::invalid_argument(format!("{flag} {s}{rest}: {why}"));
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    // An origin and a size, `X,Y,WxH`: say the corners.
    if let [x, y, size] = parts[..] {
        let sized = size.split_once(['x', 'X']);
        if let (Ok(x), Ok(y), Some((w, h))) = (x.parse::<u32>(), y.parse::<u32>(), sized) {
            if let (Ok(w), Ok(h)) = (w.parse::<u32>(), h.parse::<u32>()) {
                return Err(bad(format!(
                    "rectangles are written by their corners X0,Y0,X1,Y1 in plsr: {flag} {x},{y},{},{}{rest}",
                    x.saturating_add(w),
                    y.saturating_add(h)
                )));
            }
        }
    }
    let v: Vec<u32> = parts
        .iter()
        .map(|x| {
            x.parse::<u32>()
                .map_err(|_| bad(format!("{x:?} is not a pixel coordinate")))
        })
        .collect::<Result<_>>()?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(bad("expected the corners X0,Y0,X1,Y1".into()));
    };
    if x0 >= x1 || y0 >= y1 {
        return Err(bad(
            "the window is empty: the corners X0,Y0,X1,Y1 need X0 < X1 and Y0 < Y1 (an origin \
             X,Y and a size W,H are the corners X,Y,X+W,Y+H)"
                .into(),
        ));
    }
    if let Some((width, height)) = within {
        if x1 > width || y1 > height {
            return Err(bad(format!(
                "the window reaches past the {width}×{height} image"
            )));
        }
    }
    Ok([x0, y0, x1, y1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_w_comma_h_and_wxh_is_refused_with_the_right_spelling() {
        assert_eq!(
            parse_size("--size", "512,256", 1 << 15).unwrap(),
            (512, 256)
        );
        let e = parse_size("--size", "512x256", 1 << 15)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("sizes are written W,H in plsr: --size 512,256"),
            "{e}"
        );
        assert!(parse_size("--size", "0,5", 10).is_err());
        assert!(parse_size("--size", "11,5", 10).is_err());
        assert!(parse_size("--size", "5", 10).is_err());
        let e = parse_size("--size", "5,6,3", 10).unwrap_err().to_string();
        assert!(
            e.ends_with("--size 5,6,3: expected W,H, e.g. 1920,1080"),
            "{e}"
        );
    }

    #[test]
    fn rectangles_are_corners_and_an_origin_and_size_is_refused_with_them() {
        assert_eq!(
            parse_rect("--crop", "10,20,50,60", Some((64, 64))).unwrap(),
            [10, 20, 50, 60]
        );
        let e = parse_rect("--crop", "10,20,40x40", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("corners X0,Y0,X1,Y1 in plsr: --crop 10,20,50,60"),
            "{e}"
        );
        let e = parse_rect("--crop", "50,20,40,40", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("X,Y,X+W,Y+H"), "{e}");
        let e = parse_rect("--crop", "0,0,65,10", Some((64, 64)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("reaches past the 64×64 image"), "{e}");
        assert!(parse_rect("--crop", "1,2,3", None).is_err());
    }
}
