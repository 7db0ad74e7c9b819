//! The seal that keeps an options struct open to new fields (faer's
//! `NonExhaustive`).
//!
//! An options struct of a Hookean crate ends with a public field
//! `non_exhaustive: NonExhaustive` of a type only its own crate can make
//! (`NonExhaustive(pub(crate) ())`). A caller outside the crate therefore
//! cannot write the struct out field by field, and neither can it write
//! the seal itself: it names the fields it sets and takes the rest with
//! `..Default::default()`, so adding a field later breaks no caller.
//! Rust's `#[non_exhaustive]` would forbid `..Default::default()` too.
//!
//! Each crate has its own type, made by [`non_exhaustive_seal!`](crate::non_exhaustive_seal).

/// Defines `NonExhaustive`, the seal of the calling crate's options structs
/// (see the [`seal`](crate::seal) module): a public type whose one field
/// only that crate can write.
///
/// ```
/// mod options {
///     hookean_sparse::non_exhaustive_seal!();
///
///     /// An options struct sealed with it.
///     #[derive(Debug, Clone, PartialEq)]
///     pub struct Params {
///         /// A setting.
///         pub tol: f64,
///         /// The seal.
///         pub non_exhaustive: NonExhaustive,
///     }
///
///     impl Default for Params {
///         fn default() -> Self {
///             Params { tol: 1e-8, non_exhaustive: NonExhaustive(()) }
///         }
///     }
/// }
/// let p = options::Params { tol: 1e-6, ..Default::default() };
/// assert_eq!(p.tol, 1e-6);
/// ```
#[macro_export]
macro_rules! non_exhaustive_seal {
    () => {
        /// The seal of this crate's options structs: their last field has this
        /// type, which only this crate can make, so a caller names the fields
        /// it sets and ends with `..Default::default()` (see
        /// `hookean_sparse::seal`).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub struct NonExhaustive(pub(crate) ());
    };
}
