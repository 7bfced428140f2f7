//! Sets `avx512_intrinsics` where the compiler has the AVX-512 intrinsics stable (Rust 1.89
//! on x86-64), for `update()`'s AVX-512 merge; with an older compiler (the workspace
//! supports 1.86) `update()` runs its AVX2 loops on every x86-64 CPU.

fn main() {
    autocfg::new().emit_path_cfg(
        "std::arch::x86_64::_mm512_maskz_compress_epi32",
        "avx512_intrinsics",
    );
    autocfg::rerun_path("build.rs");
}
