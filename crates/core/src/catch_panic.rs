//! Panics a caller has chosen to contain. The third-party readers the loaders call (gltf, tobj,
//! image) may still assert on input glimpse did not foresee; the loaders run them inside
//! [`catch`], which turns a panic into an error naming the file. The command line's panic hook
//! asks [`is_catching`] so that a contained panic prints nothing and does not end the process.

use std::cell::Cell;

thread_local! {
    static CATCHING: Cell<u32> = const { Cell::new(0) };
}

/// Runs `f`, turning a panic on this thread into `Err` with its message.
pub fn catch<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    CATCHING.with(|c| c.set(c.get() + 1));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    CATCHING.with(|c| c.set(c.get() - 1));
    result.map_err(|payload| {
        payload.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| payload.downcast_ref::<String>().cloned()).unwrap_or_default()
    })
}

/// True while this thread runs inside [`catch`] (for panic hooks).
pub fn is_catching() -> bool {
    CATCHING.with(|c| c.get() > 0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_caught_panic_is_an_error_and_the_flag_is_scoped() {
        assert!(!super::is_catching());
        let r: Result<(), String> = super::catch(|| {
            assert!(super::is_catching());
            panic!("bad input")
        });
        assert_eq!(r.unwrap_err(), "bad input");
        assert!(!super::is_catching());
        assert_eq!(super::catch(|| 3), Ok(3));
    }
}
