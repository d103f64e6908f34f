//! A panic inside the composition engine becomes an error naming the root layer.
//!
//! [`crate_check`](super::crate_check) and the text normalizer keep known crashes of the `openusd`
//! crate from being reached, but the crate is large and indexes freely; a panic it still has is a
//! bug in it, not a reason for ingest to unwind through its caller. [`catch`] turns one into
//! [`UsdErrorKind::Internal`] with the panic's message and place. [`quiet_reader_panics`] (for
//! binaries) keeps the default hook from printing its banner for those panics only, so the user
//! sees one error line; panics anywhere else are reported as before.

use std::cell::{Cell, RefCell};
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

use crate::usd::{UsdError, UsdErrorKind};

thread_local! {
    /// Nesting depth of [`catch`] on this thread.
    static INSIDE: Cell<u32> = const { Cell::new(0) };
    /// Where the last panic caught by [`catch`] on this thread happened (set by the quiet hook).
    static LOCATION: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Runs `read` and returns its result, or an error naming `root_layer` if it panics.
pub(in crate::usd) fn catch<T>(
    root_layer: &str,
    read: impl FnOnce() -> Result<T, UsdError>,
) -> Result<T, UsdError> {
    INSIDE.with(|inside| inside.set(inside.get() + 1));
    let outcome = panic::catch_unwind(AssertUnwindSafe(read));
    INSIDE.with(|inside| inside.set(inside.get() - 1));
    outcome.unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "unknown panic".into());
        let message = match LOCATION.with(|l| l.borrow_mut().take()) {
            Some(at) => format!("{message} (at {at})"),
            None => message,
        };
        Err(UsdError::new(root_layer, UsdErrorKind::Internal(message)))
    })
}

/// Installs (once) a panic hook that stays silent for panics [`catch`] will report as errors and
/// defers to the previous hook for every other panic.
pub fn quiet_reader_panics() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if INSIDE.with(Cell::get) > 0 {
                let at = info.location().map(|l| format!("{}:{}", l.file(), l.line()));
                LOCATION.with(|l| *l.borrow_mut() = at);
            } else {
                previous(info);
            }
        }));
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_an_error_naming_the_root_layer() {
        quiet_reader_panics();
        let result: Result<(), UsdError> = catch("scene.usdc", || {
            let table: Vec<u32> = Vec::new();
            let index = std::hint::black_box(7);
            assert!(table.get(index).is_some(), "token index {index} out of range");
            Ok(())
        });
        let e = result.unwrap_err();
        assert!(matches!(e.kind(), UsdErrorKind::Internal(_)));
        let text = e.to_string();
        assert!(
            text.starts_with(
                "scene.usdc: the USD reader failed unexpectedly: token index 7 out of range (at "
            ),
            "{text}"
        );
        assert!(text.contains("reader_panic.rs:"), "{text}");
        // Outside `catch`, nothing is left over for the next error.
        assert!(LOCATION.with(|l| l.borrow().is_none()));
    }

    #[test]
    fn results_pass_through() {
        assert_eq!(catch("a.usda", || Ok(3)).unwrap(), 3);
        let e = catch::<()>("a.usda", || Err(UsdError::new("b.usda", UsdErrorKind::Invalid("bad".into()))));
        assert_eq!(e.unwrap_err().to_string(), "b.usda: bad");
    }
}
