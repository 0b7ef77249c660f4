//! Which instruction set a kernel runs on, detected at run time or forced by name.

use core::fmt;
use core::str::FromStr;

/// An instruction set kdbeam has kernels for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Isa {
    /// One lane, plain `f32`: the reference every SIMD path is checked against.
    Scalar,
    /// Four lanes of `wide::f32x4`, compiled for the build target's baseline (SSE2 on x86-64,
    /// NEON on aarch64, simd128 on wasm when enabled).
    Portable,
    /// Four lanes of `__m128`, SSE4.1.
    Sse,
    /// Eight lanes of `__m256`, AVX2 + FMA.
    Avx2,
    /// Sixteen lanes of `__m512` with masks in `__mmask16`, AVX-512F/BW/DQ/VL (with AVX2 + FMA).
    Avx512,
}

impl Isa {
    /// Every ISA, narrowest first.
    pub const ALL: [Isa; 5] = [Isa::Scalar, Isa::Portable, Isa::Sse, Isa::Avx2, Isa::Avx512];

    /// Lanes per vector.
    #[must_use]
    pub const fn width(self) -> usize {
        match self {
            Isa::Scalar => 1,
            Isa::Portable | Isa::Sse => 4,
            Isa::Avx2 => 8,
            Isa::Avx512 => 16,
        }
    }

    /// The name `KDBEAM_ISA` and the CLI accept: `scalar`, `portable`, `sse`, `avx2`, `avx512`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Portable => "portable",
            Isa::Sse => "sse",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// Can this CPU run it? Detected once per call site by `std_detect`'s cache.
    #[cfg(feature = "std")]
    #[inline]
    #[must_use]
    pub fn is_available(self) -> bool {
        match self {
            Isa::Scalar | Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Sse => std::is_x86_feature_detected!("sse4.1"),
            // The bit instructions came with AVX2 on every x86 CPU that has it (Haswell,
            // Excavator); the AVX2 entry point uses them for its mask and counter arithmetic.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::is_x86_feature_detected!("avx2")
                    && std::is_x86_feature_detected!("fma")
                    && std::is_x86_feature_detected!("popcnt")
                    && std::is_x86_feature_detected!("lzcnt")
                    && std::is_x86_feature_detected!("bmi1")
                    && std::is_x86_feature_detected!("bmi2")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                Isa::Avx2.is_available()
                    && std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512bw")
                    && std::is_x86_feature_detected!("avx512dq")
                    && std::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            Isa::Sse | Isa::Avx2 | Isa::Avx512 => false,
        }
    }

    /// The widest ISA this CPU runs.
    #[cfg(feature = "std")]
    #[must_use]
    pub fn detect() -> Isa {
        Isa::ALL
            .into_iter()
            .rev()
            .find(|i| i.is_available())
            .unwrap_or(Isa::Scalar)
    }

    /// Every ISA this CPU runs, narrowest first.
    #[cfg(feature = "std")]
    pub fn available() -> impl Iterator<Item = Isa> {
        Isa::ALL.into_iter().filter(|i| i.is_available())
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The name given is not an ISA kdbeam knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParseIsaError;

impl fmt::Display for ParseIsaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("unknown ISA: expected one of scalar, portable, sse, avx2, avx512")
    }
}

impl FromStr for Isa {
    type Err = ParseIsaError;

    /// Parses `scalar`, `portable`, `sse` (or `sse4.1`), `avx2` (or `avx`), `avx512`,
    /// ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        for (name, isa) in [
            ("scalar", Isa::Scalar),
            ("portable", Isa::Portable),
            ("sse", Isa::Sse),
            ("sse4.1", Isa::Sse),
            ("avx2", Isa::Avx2),
            ("avx", Isa::Avx2),
            ("avx512", Isa::Avx512),
        ] {
            if s.eq_ignore_ascii_case(name) {
                return Ok(isa);
            }
        }
        Err(ParseIsaError)
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ParseIsaError {}
