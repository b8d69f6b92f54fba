//! imunoise layer `spectral` (being built: see the crate's issue).
