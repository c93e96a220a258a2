//! regression tests.
