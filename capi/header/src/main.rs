//! `cargo run --release -p lfast-capi-header`: fails when
//! capi/include/lfast/lfast.h differs from what cbindgen generates from
//! capi/src today (the committed header is never stale). With `LFAST_BLESS=1`
//! it rewrites the header instead.

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let capi = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let config = match cbindgen::Config::from_file(capi.join("cbindgen.toml")) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("capi/cbindgen.toml: {e}");
            return ExitCode::from(2);
        }
    };
    // cbindgen follows lib.rs's `mod` declarations into the other files
    let bindings = match cbindgen::Builder::new().with_config(config).with_src(capi.join("src/lib.rs")).generate() {
        Ok(b) => b,
        Err(e) => {
            eprintln!("cbindgen cannot parse capi/src: {e}");
            return ExitCode::from(2);
        }
    };
    let mut fresh = Vec::new();
    bindings.write(&mut fresh);
    let path = capi.join("include/lfast/lfast.h");
    if std::env::var_os("LFAST_BLESS").is_some() {
        if let Err(e) = std::fs::write(&path, &fresh) {
            eprintln!("{}: {e}", path.display());
            return ExitCode::from(2);
        }
        println!("wrote {}", path.display());
        return ExitCode::SUCCESS;
    }
    if std::fs::read(&path).ok().as_deref() == Some(&fresh[..]) {
        println!("capi/include/lfast/lfast.h is current");
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "capi/include/lfast/lfast.h is stale: regenerate it with \
             `LFAST_BLESS=1 cargo run --release -p lfast-capi-header` and commit it"
        );
        ExitCode::FAILURE
    }
}
