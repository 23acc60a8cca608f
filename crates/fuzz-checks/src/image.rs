//! Image files as plsr reads them: OpenEXR (renders, parts, panoramas),
//! Radiance HDR, PNG and JPEG (photos, brackets, textures, masks). The
//! first input byte picks the format, the rest is the file. Every reader
//! must refuse a header whose size does not fit the file or the memory
//! before allocating for it (docs/errors.md): a 4 KiB input that makes a
//! reader allocate beyond libFuzzer's `-malloc_limit_mb` is a finding.

/// Checks one input.
pub fn check(data: &[u8]) {
    let Some((&kind, file)) = data.split_first() else {
        return;
    };
    let name = ["image.exr", "image.hdr", "image.png", "image.jpg"][usize::from(kind % 4)];
    let path = crate::common::input_file(name, file);
    let names = [name];
    match kind % 4 {
        0 => {
            if let Err(e) = plsr::film::Film::read_exr(&path) {
                crate::common::assert_clean_error(&e.to_string(), &names);
            }
            if let Err(e) = plsr::film::part::Part::read_exr(&path) {
                crate::common::assert_clean_error(&e.to_string(), &names);
            }
            let _ = plsr_base::exr_header::header_fault(&path);
        }
        1 => {
            if let Ok((w, h, pixels)) = plsr::film::radiance::read_radiance_hdr(&path) {
                assert_eq!(pixels.len(), w as usize * h as usize);
            }
        }
        _ => {}
    }
    // Every format also goes through the reader of photos and brackets.
    match plsr_oiio::ImageReader::open(&path) {
        Ok(mut reader) => {
            let info = reader.info().clone();
            match reader.read_all::<f32>() {
                Ok(pixels) => {
                    assert_eq!(pixels.len(), info.width * info.height * info.channels)
                }
                Err(e) => crate::common::assert_clean_error(&e.to_string(), &names),
            }
        }
        Err(e) => crate::common::assert_clean_error(&e.to_string(), &names),
    }
}
