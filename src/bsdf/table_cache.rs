//! Tables computed once per distinct parameter and kept for the life of
//! the process (the principled BSDF's dielectric albedo, the rough
//! plastic's transmittance): shared by all threads, each thread keeping
//! the last few it used so that a lookup rarely takes the lock.

use std::cell::RefCell;
use std::sync::Mutex;
use std::thread::LocalKey;

/// How many tables each thread keeps at hand.
pub(crate) const RECENT_LEN: usize = 16;

/// The table `same` recognises: from this thread's `recent` list, else from
/// `all` (shared), else `compute`d, leaked and added to `all`. `compute`
/// runs under the lock, so each table is computed once.
pub(crate) fn interned<T: 'static>(
    all: &Mutex<Vec<&'static T>>,
    recent: &'static LocalKey<RefCell<Vec<&'static T>>>,
    same: impl Fn(&T) -> bool,
    compute: impl FnOnce() -> T,
) -> &'static T {
    if let Some(t) = recent.with(|r| r.borrow().iter().find(|t| same(t)).copied()) {
        return t;
    }
    let table = {
        // A panic while computing leaves nothing half-inserted, so a
        // poisoned list is still consistent.
        let mut all = all.lock().unwrap_or_else(|e| e.into_inner());
        match all.iter().find(|t| same(t)) {
            Some(t) => *t,
            None => {
                let t: &'static T = Box::leak(Box::new(compute()));
                all.push(t);
                t
            }
        }
    };
    recent.with(|r| {
        let mut r = r.borrow_mut();
        if r.len() == RECENT_LEN {
            r.remove(0);
        }
        r.push(table);
    });
    table
}
