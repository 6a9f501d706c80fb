//! Says which SIMD pair-pass paths the tests of this build run, as `cfg`s: `path_avx2` (the
//! CPU has AVX and AVX2) and `path_avx512` (AVX-512F and DQ): the features
//! `KernelPath::detect` asks for, less those `DEM_VERIFY_MAX_KERNEL` excludes (CI's run "as a
//! CPU without AVX2"). A test of a path that does not run here is marked ignored with its
//! reason, so `cargo test` lists it as ignored, never as passed; where the path runs, the
//! test asserts it at run time too (a test binary built on one machine and run on another
//! fails, it does not skip). `cargo test` builds and runs on one machine: the build script's
//! CPU is the tests' CPU.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(path_avx2)");
    println!("cargo::rustc-check-cfg=cfg(path_avx512)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=DEM_VERIFY_MAX_KERNEL");
    let cap = std::env::var("DEM_VERIFY_MAX_KERNEL").ok();
    // an unknown value is the library's error to report (KernelPath::max_from_env): the
    // build treats it as no cap
    let allows = |path: &str| match cap.as_deref() {
        Some("scalar") => false,
        Some("avx2") => path == "avx2",
        _ => true,
    };
    let x86 = std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("x86_64");
    let (avx2, avx512) = host_paths();
    if x86 && avx2 && allows("avx2") {
        println!("cargo::rustc-cfg=path_avx2");
    }
    if x86 && avx512 && allows("avx512") {
        println!("cargo::rustc-cfg=path_avx512");
    }
}

/// The building CPU's (AVX2, AVX-512) paths.
fn host_paths() -> (bool, bool) {
    #[cfg(target_arch = "x86_64")]
    {
        (
            std::arch::is_x86_feature_detected!("avx")
                && std::arch::is_x86_feature_detected!("avx2"),
            std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512dq"),
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        (false, false)
    }
}
