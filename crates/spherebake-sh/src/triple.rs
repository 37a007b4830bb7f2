//! Triple products.
