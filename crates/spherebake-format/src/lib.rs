//! spherebake-format
