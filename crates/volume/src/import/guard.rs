//! Runs third-party parsing code that may panic on malformed input and turns the panic into
//! an error, without the default hook printing a backtrace to the user's terminal.

use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

static INSTALL: Once = Once::new();

/// Calls `f`; a panic inside it becomes `Err(message)`. Panics elsewhere, and on other
/// threads, are reported by the previously installed hook as usual.
pub(crate) fn catch_panic<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    INSTALL.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let was = QUIET.with(|q| q.replace(true));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(was));
    result.map_err(|payload| {
        if let Some(s) = payload.downcast_ref::<&str>() {
            (*s).to_string()
        } else if let Some(s) = payload.downcast_ref::<String>() {
            s.clone()
        } else {
            "the reader failed on malformed data".to_string()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panics_become_errors() {
        assert_eq!(catch_panic(|| 7), Ok(7));
        let r: Result<(), String> = catch_panic(|| panic!("Not supported {}", "AffineMap"));
        assert_eq!(r, Err("Not supported AffineMap".to_string()));
        let v: Vec<u8> = Vec::new();
        let r = catch_panic(|| v[3]);
        assert!(r.unwrap_err().contains("index out of bounds"));
    }
}
