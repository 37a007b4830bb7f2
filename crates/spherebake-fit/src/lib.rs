//! spherebake-fit
