//! Which kernel path evaluates the pair contacts: the scalar chain or a SIMD pass, chosen
//! at run time from what the CPU has (and `DEM_VERIFY_MAX_KERNEL`).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Which implementation evaluates the pair contacts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelPath {
    /// One contact at a time ([`surfaces_intersect`]).
    Scalar,
    /// 8 contacts per AVX-512 vector ([`batch::pair`]).
    Avx512,
    /// 4 contacts per AVX vector ([`batch::pair`]), on CPUs with AVX2 but without AVX-512.
    Avx2,
}

impl KernelPath {
    /// The fastest path this CPU runs (and [`MAX_KERNEL_VAR`] allows).
    pub fn detect() -> Self {
        [KernelPath::Avx512, KernelPath::Avx2]
            .into_iter()
            .find(|k| k.runs_here())
            .unwrap_or(KernelPath::Scalar)
    }

    /// Every path this CPU runs, the scalar one first.
    pub fn available() -> Vec<Self> {
        [KernelPath::Scalar, KernelPath::Avx2, KernelPath::Avx512]
            .into_iter()
            .filter(|k| k.runs_here())
            .collect()
    }

    /// This CPU has the path's instructions, and [`MAX_KERNEL_VAR`] does not exclude it.
    pub fn runs_here(self) -> bool {
        let cpu = match self {
            KernelPath::Scalar => true,
            KernelPath::Avx512 => avx512_available(),
            KernelPath::Avx2 => avx2_available(),
        };
        cpu && self.rank() <= max_kernel().rank()
    }

    /// Scalar < AVX2 < AVX-512.
    fn rank(self) -> u8 {
        match self {
            KernelPath::Scalar => 0,
            KernelPath::Avx2 => 1,
            KernelPath::Avx512 => 2,
        }
    }

    /// The fastest path [`MAX_KERNEL_VAR`] allows: Ok(None) when it is unset; an error
    /// naming the variable and its values for anything else than a path's name.
    pub fn max_from_env() -> Result<Option<Self>> {
        match std::env::var(MAX_KERNEL_VAR) {
            Err(std::env::VarError::NotPresent) => Ok(None),
            Ok(v) => [KernelPath::Scalar, KernelPath::Avx2, KernelPath::Avx512]
                .into_iter()
                .find(|k| k.name() == v)
                .map(Some)
                .ok_or_else(|| Error::invalid(MAX_KERNEL_VAR, v, "one of scalar, avx2, avx512")),
            Err(e) => Err(Error::invalid(
                MAX_KERNEL_VAR,
                "(not unicode)",
                format!("one of scalar, avx2, avx512 ({e})"),
            )),
        }
    }

    /// `path` if this CPU can run it, else an error naming `field`.
    pub fn checked(self, field: &str) -> Result<Self> {
        if !self.runs_here() {
            let names: Vec<_> = Self::available().iter().map(|k| k.name()).collect();
            return Err(Error::invalid(
                field,
                self.name(),
                format!("one of {} on this CPU", names.join(", ")),
            ));
        }
        Ok(self)
    }

    pub fn name(self) -> &'static str {
        match self {
            KernelPath::Scalar => "scalar",
            KernelPath::Avx512 => "avx512",
            KernelPath::Avx2 => "avx2",
        }
    }
}

/// The environment variable that makes the solver act as a CPU without the faster paths
/// (`scalar`: neither AVX2 nor AVX-512; `avx2`: no AVX-512; `avx512` or unset: what the CPU
/// has), so that a machine with AVX-512 runs the whole test suite as one without it would.
pub const MAX_KERNEL_VAR: &str = "DEM_VERIFY_MAX_KERNEL";

/// The fastest path allowed in this process (read once; `verify` checks the variable at
/// start and refuses a bad value before any solver runs).
fn max_kernel() -> KernelPath {
    static MAX: std::sync::OnceLock<KernelPath> = std::sync::OnceLock::new();
    *MAX.get_or_init(|| match KernelPath::max_from_env() {
        Ok(k) => k.unwrap_or(KernelPath::Avx512),
        Err(e) => panic!("{e}"),
    })
}

fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx") && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn avx512_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
