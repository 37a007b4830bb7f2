//! spherebake-io
