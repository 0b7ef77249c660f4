//! Choosing an ISA once and running [`LaneTask`]s on it.

use core::fmt;

#[cfg(target_arch = "x86_64")]
use super::{Avx, Avx512, Sse};
use super::{Isa, LaneTask, Lanes, Portable, Scalar};

/// An ISA this CPU was checked to run: the one way kdbeam runs a [`LaneTask`] on an ISA chosen
/// at run time.
///
/// The check is made once, when a `Dispatch` is made ([`Dispatch::new`], [`Dispatch::detect`],
/// [`Dispatch::from_env`]); [`Dispatch::run`] then makes the ISA's token with
/// `new_unchecked`, without asking the CPU again, and enters the task's `#[target_feature]`
/// entry point. A tracer or a tree builder makes one when it is made and runs every packet and
/// every split search through it.
///
/// memchr caches a function pointer, because each of its searches is one non-generic function;
/// kdbeam's tasks are generic (a pointer would be needed per task type), so what is cached is
/// the checked ISA, and `run` is a `match` on it: a branch that always goes the same way.
///
/// Every ISA stays reachable on its own: [`Dispatch::new`] with any [`Isa`] this CPU runs
/// ([`Dispatch::available`] lists them), which is how the tests compare each SIMD path with
/// [`Isa::Scalar`].
///
/// ```
/// use kdbeam_kernels::lanes::Dispatch;
/// use kdbeam_kernels::{Isa, LaneF32, LaneTask, Lanes};
///
/// /// `2 · 3` in every lane, summed.
/// struct SumOfProducts;
///
/// impl LaneTask for SumOfProducts {
///     type Output = f32;
///     #[inline(always)]
///     fn run<L: Lanes>(self, l: L) -> f32 {
///         let v = l.splat(2.0) * l.splat(3.0);
///         (0..L::WIDTH).map(|i| v.extract(i)).sum()
///     }
/// }
///
/// assert_eq!(Dispatch::SCALAR.run(SumOfProducts), 6.0);
/// let best = Dispatch::detect();
/// assert_eq!(best.run(SumOfProducts), 6.0 * best.isa().width() as f32);
/// # #[cfg(feature = "std")]
/// for d in Dispatch::available() {
///     assert_eq!(d.run(SumOfProducts), 6.0 * d.isa().width() as f32);
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dispatch {
    /// Checked to run on this CPU (the only invariant: every constructor checks or is `unsafe`).
    isa: Isa,
}

impl Dispatch {
    /// [`Isa::Scalar`], which every CPU runs.
    pub const SCALAR: Dispatch = Dispatch { isa: Isa::Scalar };
    /// [`Isa::Portable`], which every CPU runs (it is compiled for the build target).
    pub const PORTABLE: Dispatch = Dispatch { isa: Isa::Portable };

    /// `isa`, if this CPU runs it.
    ///
    /// # Errors
    /// [`IsaError::Unavailable`] otherwise (always for [`Isa::Sse`], [`Isa::Avx2`] and
    /// [`Isa::Avx512`] off x86-64).
    #[cfg(feature = "std")]
    pub fn new(isa: Isa) -> Result<Dispatch, IsaError> {
        if isa.is_available() {
            Ok(Dispatch { isa })
        } else {
            Err(IsaError::Unavailable(isa))
        }
    }

    /// `isa`, without checking the CPU (for `no_std` builds, which cannot detect it).
    ///
    /// # Safety
    /// The CPU running the program must support `isa`: [`Dispatch::run`] executes its
    /// instructions.
    #[must_use]
    pub const unsafe fn new_unchecked(isa: Isa) -> Dispatch {
        Dispatch { isa }
    }

    /// The widest ISA this CPU runs ([`Isa::detect`]); [`Dispatch::SCALAR`] without the `std`
    /// feature.
    #[must_use]
    pub fn detect() -> Dispatch {
        #[cfg(feature = "std")]
        let isa = Isa::detect();
        #[cfg(not(feature = "std"))]
        let isa = Isa::Scalar;
        Dispatch { isa }
    }

    /// Every ISA this CPU runs, narrowest first.
    #[cfg(feature = "std")]
    pub fn available() -> impl Iterator<Item = Dispatch> {
        Isa::available().map(|isa| Dispatch { isa })
    }

    /// The ISA the environment variable `KDBEAM_ISA` forces, if it is set and not blank: one of
    /// the names [`Isa`]'s `FromStr` accepts (`scalar`, `portable`, `sse`, `avx2`, `avx512`, any
    /// case).
    ///
    /// # Errors
    /// [`IsaError::UnknownName`] when the variable names no ISA, [`IsaError::Unavailable`]
    /// when this CPU does not run it.
    #[cfg(feature = "std")]
    pub fn from_env() -> Result<Option<Dispatch>, IsaError> {
        match std::env::var("KDBEAM_ISA") {
            Ok(name) if !name.trim().is_empty() => match name.parse::<Isa>() {
                Ok(isa) => Dispatch::new(isa).map(Some),
                Err(_) => Err(IsaError::UnknownName(name)),
            },
            _ => Ok(None),
        }
    }

    /// The ISA `KDBEAM_ISA` forces when that is valid and available, otherwise the widest this
    /// CPU runs: the default of tracers and tree builders (they do not fail on a bad variable;
    /// a program that wants to report it calls [`Dispatch::from_env`]).
    #[cfg(feature = "std")]
    #[must_use]
    pub fn preferred() -> Dispatch {
        Dispatch::from_env()
            .ok()
            .flatten()
            .unwrap_or_else(Dispatch::detect)
    }

    /// The ISA tasks run on.
    #[must_use]
    pub const fn isa(self) -> Isa {
        self.isa
    }

    /// Runs `task` on this ISA: makes its token and calls [`Lanes::run`].
    #[inline]
    pub fn run<T: LaneTask>(self, task: T) -> T::Output {
        match self.isa {
            Isa::Scalar => Scalar.run(task),
            Isa::Portable => Portable.run(task),
            #[cfg(target_arch = "x86_64")]
            Isa::Sse => {
                // SAFETY: `self.isa` is `Sse` only if `Dispatch::new` found SSE4.1 on this CPU
                // or the caller of `new_unchecked` promised it.
                unsafe { Sse::new_unchecked() }.run(task)
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                // SAFETY: `self.isa` is `Avx2` only if `Dispatch::new` found AVX2, FMA and the bit
                // instructions on this CPU or the caller of `new_unchecked` promised them.
                unsafe { Avx::new_unchecked() }.run(task)
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                // SAFETY: `self.isa` is `Avx512` only if `Dispatch::new` found AVX-512F/BW/DQ/VL
                // and the AVX2 token's features on this CPU or the caller of `new_unchecked`
                // promised them.
                unsafe { Avx512::new_unchecked() }.run(task)
            }
            #[cfg(not(target_arch = "x86_64"))]
            Isa::Sse | Isa::Avx2 | Isa::Avx512 => {
                unreachable!("no constructor admits an x86 ISA off x86-64")
            }
        }
    }
}

impl fmt::Display for Dispatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.isa.fmt(f)
    }
}

/// Why an ISA cannot be used.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum IsaError {
    /// This CPU (or target) does not run the ISA.
    Unavailable(Isa),
    /// `KDBEAM_ISA` holds this value, which names no ISA.
    #[cfg(feature = "std")]
    UnknownName(std::string::String),
}

impl fmt::Display for IsaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IsaError::Unavailable(isa) => {
                write!(f, "the {isa} instruction set is not available on this CPU")
            }
            #[cfg(feature = "std")]
            IsaError::UnknownName(name) => {
                write!(f, "{}, got {name:?}", super::ParseIsaError)
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for IsaError {}
