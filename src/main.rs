//! `lfast`: command-line front end. The work is in the library (`lfast::cli`).

fn main() -> std::process::ExitCode {
    // `lfast info | head` must end quietly like any Unix tool, not panic in
    // println! on a closed pipe: restore the default SIGPIPE action (Rust ignores it).
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is a valid handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    lfast::cli::main()
}
