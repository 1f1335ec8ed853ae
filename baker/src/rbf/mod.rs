//! Radial basis functions: the kernels, the interpolation system with its optional affine block
//! and per-centre stiffness, and the per-vertex weights it implies.
//!
//! The deformation `f(v) = Σ_i α_i φ_i(‖v − x_i‖) + β · [1, v]` (thesis §2.4 eqs 2.1–2.6, paper 000
//! eqs 13–16, paper 003 eqs 10–11) is linear in the marker displacements `D`:
//! `[α; β] = A⁻¹ [D; 0]`, so the displacement of a vertex is `g(v)ᵀ A⁻¹ [D; 0]` with
//! `g(v) = [φ_1(‖v − x_1‖) … φ_n(‖v − x_n‖), 1, v]`. The per-vertex weights are therefore the first
//! `n` entries of `A⁻ᵀ g(v)`, computed once in f64 here.

pub mod radial;
pub mod system;

pub use radial::{Kernel, RadialFunction};
pub use system::{RbfSystem, SolveError};
