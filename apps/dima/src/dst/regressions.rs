//! Seeds that found a defect, replayed: each must now run without a violation.
