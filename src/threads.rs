//! Worker threads: the rayon pool every parallel stage of plsr runs on.

use crate::accel::enable_flush_to_zero;
use crate::error::{Error, Result};

/// A rayon pool whose workers run with flush-to-zero and denormals-are-zero,
/// as Embree requires of every thread that traces rays.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new().start_handler(|_| enable_flush_to_zero());
    if let Some(n) = threads {
        if n == 0 {
            return Err(Error::InvalidArgument(
                "thread count must be at least 1".into(),
            ));
        }
        b = b.num_threads(n);
    }
    b.build()
        .map_err(|e| Error::InvalidArgument(format!("cannot start worker threads: {e}")))
}
