//! Sets the cfg `simd_vectors` where the target's baseline instruction set has the two-lane f64
//! vectors the explicit vector kernels are written for: x86-64 (SSE2; AVX2 and AVX-512 are
//! detected at run time) and aarch64 with NEON (Advanced SIMD, in the baseline of every
//! aarch64 Linux, macOS and Windows target). Elsewhere only the portable code is built.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(simd_vectors)");
    println!("cargo::rerun-if-changed=build.rs");
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let features = std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    let neon = features.split(',').any(|f| f == "neon");
    if arch == "x86_64" || (arch == "aarch64" && neon) {
        println!("cargo::rustc-cfg=simd_vectors");
    }
}
