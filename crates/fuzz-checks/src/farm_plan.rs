//! Farm plans (`farm.toml`, docs/farm.md) as `farm status`, `farm piece`
//! and `farm merge` read them back: a plan that passes its checks, or an
//! error naming the file.

/// Checks one input.
pub fn check(data: &[u8]) {
    let path = crate::common::input_file("farm.toml", data);
    match plsr_cli::farm::plan::FarmPlan::read(&path) {
        Err(e) => crate::common::assert_clean_error(&e.to_string(), &["farm.toml"]),
        Ok(plan) => assert!(plan.check().is_ok()),
    }
}
