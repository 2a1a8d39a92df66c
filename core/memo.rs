//! Process-wide memos of pure reference functions. A process that checks several
//! files of one family (the corruption sweep: one check per corrupted copy; an export
//! measured under each filter; `check --export` after `export` in the tests) asks the
//! references at the same points again, and they are quadratures or fits costing up
//! to milliseconds a point. The memo only avoids recomputation: a value is a pure
//! function of its key, the inputs' bit patterns.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Entries a memo keeps before it stops adding (about 100 MB at worst: a memo never
/// grows without bound in a long-running process).
const CAPACITY: usize = 1 << 20;

/// A memo of a pure function of `N` f64 inputs (see the module doc).
pub struct Memo<const N: usize, V> {
    map: OnceLock<Mutex<HashMap<[u64; N], V>>>,
}

impl<const N: usize, V: Clone> Memo<N, V> {
    /// An empty memo (for a `static`).
    pub const fn new() -> Self {
        Memo { map: OnceLock::new() }
    }

    /// `f()`, or its value from an earlier call with the same `key` (bit for bit).
    /// Errors are not kept. The lock is not held while `f` runs.
    pub fn get<E>(&self, key: [f64; N], f: impl FnOnce() -> Result<V, E>) -> Result<V, E> {
        let map = self.map.get_or_init(Default::default);
        let bits = key.map(f64::to_bits);
        // A poisoned lock only means another thread panicked mid-insert of a pure
        // value: the map is still valid.
        if let Some(v) = map.lock().unwrap_or_else(|e| e.into_inner()).get(&bits) {
            return Ok(v.clone());
        }
        let v = f()?;
        let mut m = map.lock().unwrap_or_else(|e| e.into_inner());
        if m.len() < CAPACITY {
            m.insert(bits, v.clone());
        }
        Ok(v)
    }
}

impl<const N: usize, V: Clone> Default for Memo<N, V> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn computes_once_per_key_and_keeps_no_errors() {
        static M: Memo<2, f64> = Memo::new();
        let mut calls = 0;
        let mut f = |x: f64, y: f64| {
            M.get([x, y], || {
                calls += 1;
                if x < 0.0 {
                    Err("negative")
                } else {
                    Ok(x + y)
                }
            })
        };
        assert_eq!(f(1.0, 2.0), Ok(3.0));
        assert_eq!(f(1.0, 2.0), Ok(3.0));
        assert_eq!(f(-0.0, 2.0), Ok(2.0), "-0.0 is another key than 0.0");
        assert_eq!(f(-1.0, 2.0), Err("negative"));
        assert_eq!(f(-1.0, 2.0), Err("negative"));
        assert_eq!(calls, 4, "one call per distinct key, errors recomputed");
    }
}
