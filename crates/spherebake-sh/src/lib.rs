//! spherebake-sh
