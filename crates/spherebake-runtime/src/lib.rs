//! spherebake-runtime
