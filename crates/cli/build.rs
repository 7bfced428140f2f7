//! Link options of the `petriplc` binary.

fn main() {
    // Relative relocations packed (DT_RELR): a position-independent Rust binary carries one
    // 24-byte relocation per pointer in its tables (about 54 000, 1.3 MB of the 25 MB);
    // packed, they take a few kilobytes, and address-space randomisation stays. GNU ld
    // (2.38+), lld and mold support it; ld leaves it out by itself when the C library is too
    // old to apply it (glibc < 2.36), so the binary always runs where it was built.
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let env = std::env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    if os == "linux" && env == "gnu" {
        println!("cargo:rustc-link-arg-bins=-Wl,-z,pack-relative-relocs");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
