//! imunoise layer `avar` (being built: see the crate's issue).
