//! libFuzzer target: `plsr_fuzz_checks::calibration` (its doc says what is fuzzed).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| plsr_fuzz_checks::calibration::check(data));
