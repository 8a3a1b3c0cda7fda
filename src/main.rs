//! `lfast`: command-line front end. The work is in the library (`lfast::cli`).

fn main() -> std::process::ExitCode {
    // `lfast info | head` must end quietly like any Unix tool, not panic in
    // println! on a closed pipe: restore the default SIGPIPE action (Rust ignores it).
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is a valid handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let _runtime_dir = quiet_headless_vulkan();
    lfast::cli::main()
}

/// On a headless machine Mesa's Vulkan drivers (lavapipe among them) print
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` while the
/// backend is chosen, so a first run would open with an error line that is not
/// lfast's. When the variable is unset, empty or not an absolute path, point it
/// at a private temporary directory (mode 0700, removed when the returned guard
/// drops at exit) before any Vulkan instance exists. The binary does this, and
/// the Python package; the library leaves the environment alone, since
/// embedders own it.
fn quiet_headless_vulkan() -> Option<tempfile::TempDir> {
    #[cfg(unix)]
    {
        let valid = std::env::var_os("XDG_RUNTIME_DIR")
            .is_some_and(|v| std::path::Path::new(&v).is_absolute() && std::path::Path::new(&v).is_dir());
        if valid {
            return None;
        }
        let dir = tempfile::Builder::new().prefix("lfast-runtime-").tempdir().ok()?;
        // SAFETY: called at the start of main, before any other thread exists
        // (nothing has read the environment concurrently yet).
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", dir.path()) };
        Some(dir)
    }
    #[cfg(not(unix))]
    None
}
