//! The shared library is installed as liblfast.so.0 (capi/install.sh): give
//! it that SONAME, so programs linked against it load it by that name.
fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,liblfast.so.0");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
