//! The per-thread last error and the codes the functions return.

use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use kdbeam::Error;

thread_local! {
    /// What the last `kdbeam_*` call on this thread reported: "" after a success.
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// A failure: its code and the text `kdbeam_last_error` returns.
pub(crate) struct Failure {
    pub code: i32,
    pub message: String,
}

impl Failure {
    pub(crate) fn new(code: i32, message: impl Into<String>) -> Self {
        Failure {
            code,
            message: message.into(),
        }
    }

    pub(crate) fn null(what: &str) -> Self {
        Failure::new(crate::KDBEAM_ERROR_NULL_POINTER, format!("{what} is NULL"))
    }
}

impl From<Error> for Failure {
    fn from(e: Error) -> Self {
        let code = match e {
            Error::UnknownGeometry(_) | Error::UnknownInstance(_) => crate::KDBEAM_ERROR_UNKNOWN_ID,
            Error::NotCommitted => crate::KDBEAM_ERROR_NOT_COMMITTED,
            Error::InvalidTransform(_) => crate::KDBEAM_ERROR_INVALID_TRANSFORM,
            Error::GeometryInUse { .. } => crate::KDBEAM_ERROR_IN_USE,
            Error::NonFinite { .. }
            | Error::IndexOutOfRange { .. }
            | Error::MalformedMesh(_)
            | Error::VertexCountChanged { .. } => crate::KDBEAM_ERROR_INVALID_MESH,
            _ => crate::KDBEAM_ERROR_INVALID_ARGUMENT,
        };
        Failure::new(code, e.to_string())
    }
}

/// Records `message` (its NUL bytes dropped) as this thread's last error.
fn set(message: &str) {
    let text = CString::new(message.replace('\0', "")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

/// Runs `f` with the panic caught: success clears the last error, a failure or a panic sets it
/// and returns `on_error(code)`.
pub(crate) fn guard<T>(
    on_error: impl FnOnce(i32) -> T,
    f: impl FnOnce() -> Result<T, Failure>,
) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => {
            set("");
            v
        }
        Ok(Err(failure)) => {
            set(&failure.message);
            on_error(failure.code)
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            set(&format!("internal error (a panic, caught): {what}"));
            on_error(crate::KDBEAM_ERROR_INTERNAL)
        }
    }
}

/// This thread's last error, valid until the thread's next `kdbeam_*` call.
pub(crate) fn text() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}
