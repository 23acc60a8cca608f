//! Worker threads: the rayon pool every parallel stage of plsr runs on.

use crate::accel::enable_flush_to_zero;
use crate::error::{Error, Result};

/// Worker threads allowed per core of the machine: more only costs
/// memory and start-up time (100 000 threads take minutes to start).
pub const MAX_THREADS_PER_CORE: usize = 8;

/// The most worker threads a pool may have on this machine:
/// [`MAX_THREADS_PER_CORE`] per core, and at least 64.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (MAX_THREADS_PER_CORE * cores).max(64)
}

/// A rayon pool whose workers run with flush-to-zero and denormals-are-zero,
/// as Embree requires of every thread that traces rays. `threads` is 1 to
/// [`max_threads`]; `None` uses every core.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new().start_handler(|_| enable_flush_to_zero());
    if let Some(n) = threads {
        if n == 0 {
            return Err(Error::InvalidArgument(
                "thread count must be at least 1".into(),
            ));
        }
        if n > max_threads() {
            return Err(Error::InvalidArgument(format!(
                "thread count {n} is more than {} ({MAX_THREADS_PER_CORE} per core of this machine)",
                max_threads()
            )));
        }
        b = b.num_threads(n);
    }
    b.build()
        .map_err(|e| Error::InvalidArgument(format!("cannot start worker threads: {e}")))
}
