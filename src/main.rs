//! `lfast`: command-line front end. The work is in the library (`lfast::cli`).

fn main() -> std::process::ExitCode {
    lfast::cli::main()
}
