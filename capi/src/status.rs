//! Status codes, the per-thread last error, and the guard that keeps panics
//! on the Rust side of the boundary.

use std::cell::RefCell;
use std::ffi::{CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// What a call returned. `LFAST_STATUS_OK` is 0; on any other value
/// `lfast_last_error()` says what was wrong, and no output was written.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LfastStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument was NULL.
    NullPointer = 1,
    /// An image, mask, keypoint or enum value is invalid (empty, stride smaller
    /// than a row, unknown pixel format, mask of another size, keypoint outside
    /// the image...).
    InvalidArgument = 2,
    /// A configuration field is out of range, or the TOML text does not parse.
    InvalidConfig = 3,
    /// A file could not be read or decoded.
    Io = 4,
    /// The GPU could not run the request (no adapter, device lost, out of
    /// memory, over a device limit).
    Gpu = 5,
    /// The request is not available in this build or on this backend.
    Unsupported = 6,
    /// An internal error (a Rust panic) was caught; the detector stays usable.
    Panic = 7,
    /// Any other library error.
    Other = 8,
}

/// An error before the library is reached: a status and its message.
pub(crate) struct Failure(pub LfastStatus, pub String);

impl From<lfast::Error> for Failure {
    fn from(e: lfast::Error) -> Self {
        use lfast::Error as E;
        let status = match &e {
            E::InvalidConfig { .. } | E::ConfigParse { .. } => LfastStatus::InvalidConfig,
            E::InvalidImage { .. } | E::MaskSize { .. } | E::InvalidKeypoint { .. } => LfastStatus::InvalidArgument,
            E::Io { .. } | E::Image { .. } => LfastStatus::Io,
            E::NoAdapter { .. }
            | E::GpuLimits { .. }
            | E::GpuOutOfMemory { .. }
            | E::DeviceLost { .. }
            | E::Gpu { .. } => LfastStatus::Gpu,
            E::Unsupported { .. } => LfastStatus::Unsupported,
            _ => LfastStatus::Other,
        };
        Failure(status, e.to_string())
    }
}

/// A NULL pointer argument named `what`.
pub(crate) fn null(what: &str) -> Failure {
    Failure(LfastStatus::NullPointer, format!("`{what}` is NULL"))
}

/// An invalid argument with its message.
pub(crate) fn invalid(msg: impl Into<String>) -> Failure {
    Failure(LfastStatus::InvalidArgument, msg.into())
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last_error(msg: &str) {
    // an interior NUL would cut the C string short: show it as `\0`
    let c = CString::new(msg.replace('\0', "\\0")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// Pointer to this thread's last error message (empty before any failure).
pub(crate) fn last_error_ptr() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Runs `f`, turning its error or panic into a status and the thread's last
/// error message. Nothing unwinds out of here.
pub(crate) fn guard(f: impl FnOnce() -> Result<(), Failure>) -> LfastStatus {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => LfastStatus::Ok,
        Ok(Err(Failure(status, msg))) => {
            set_last_error(&msg);
            status
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic payload".into());
            set_last_error(&format!("internal error (panic caught at the C boundary): {what}"));
            LfastStatus::Panic
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    fn last() -> String {
        unsafe { CStr::from_ptr(last_error_ptr()) }.to_string_lossy().into_owned()
    }

    #[test]
    fn a_panic_becomes_a_status_and_a_message() {
        let s = guard(|| panic!("boom {}", 7));
        assert_eq!(s, LfastStatus::Panic);
        assert!(last().contains("boom 7"), "{}", last());
        let s = guard(|| std::panic::panic_any(3_u8));
        assert_eq!(s, LfastStatus::Panic);
        assert!(last().contains("unknown panic payload"));
    }

    #[test]
    fn errors_keep_their_message_and_success_leaves_it() {
        assert_eq!(guard(|| Err(null("image"))), LfastStatus::NullPointer);
        assert_eq!(last(), "`image` is NULL");
        assert_eq!(guard(|| Ok(())), LfastStatus::Ok);
        assert_eq!(last(), "`image` is NULL");
        assert_eq!(guard(|| Err(invalid("a\0b"))), LfastStatus::InvalidArgument);
        assert_eq!(last(), "a\\0b");
    }

    #[test]
    fn library_errors_map_to_their_status() {
        let e = lfast::Error::InvalidConfig { field: "support", reason: "must be 1..=8".into() };
        let Failure(s, m) = e.into();
        assert_eq!(s, LfastStatus::InvalidConfig);
        assert!(m.contains("support"));
        let Failure(s, _) = lfast::Error::MaskSize { mask_width: 1, mask_height: 1, width: 2, height: 2 }.into();
        assert_eq!(s, LfastStatus::InvalidArgument);
        let Failure(s, _) = lfast::Error::NoAdapter { reason: "none".into() }.into();
        assert_eq!(s, LfastStatus::Gpu);
    }
}
