//! The program's error: whatever any library reported, printed once at the
//! edge as `plsr: error: …` (see `main`). The applications' enum already
//! holds every library's error, so the program reports through it.

pub use plsr_apps::{Error, Result};
