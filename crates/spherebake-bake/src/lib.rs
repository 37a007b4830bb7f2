//! spherebake-bake
