//! imunoise layer `gmwm_prep` (being built: see the crate's issue).
