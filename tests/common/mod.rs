//! Test helpers shared by the integration tests (`mod common;` in each).
//!
//! Not every test uses every helper.
#![allow(dead_code)]

pub mod chi2;
