//! plsr's denoiser: Intel Open Image Denoise's "RT" filter (a U-Net guided
//! by the albedo and normal of the first hit) run natively on the CPU with
//! OIDN's own trained weights (`assets/oidn/`, Apache-2.0), so that a render
//! of a few dozen samples per pixel comes out clean (docs/denoising.md).
//!
//! The pieces, from the outside in: [`filter::denoise`] (the RT filter),
//! [`unet`] (the network), [`conv`], [`upconv`] and [`planes`] (its layers),
//! [`transfer`] and [`autoexposure`] (how values are encoded for it),
//! [`weights`] (which trained weights for which images) and [`tza`] (their
//! container).

pub mod autoexposure;
pub mod conv;
pub mod filter;
pub mod planes;
pub mod transfer;
pub mod tza;
pub mod unet;
pub mod upconv;
pub mod weights;

pub use filter::{denoise, denoise_prefiltered, prefilter, Aux, FilterError, Image, Options};
